"""Interoperability with Debian's lrzsz: ``sx`` sends to our receiver, ``rx`` receives from our
sender, over subprocess pipes, with real time. Checksum, CRC-16 and 1K blocks.

``rx`` waits a fixed second after EOT to make sure it was not noise, so the ``rx`` transfers run
side by side in threads (one module-scoped fixture) to keep the suite fast.
"""

from __future__ import annotations

import random
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from xmodem_line import End
from xmodem_pump import pump

from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender
from sondalog.protocol.xmodem.frames import ACK, SOH, STX, SUB

pytestmark = pytest.mark.skipif(
    shutil.which("sx") is None or shutil.which("rx") is None,
    reason="lrzsz (sx, rx) not installed",
)

SIZES = [1, 128, 1024, 1000, 100_003]
MODES = ["checksum", "crc", "1k"]


def payload(size: int) -> bytes:
    return random.Random(size).randbytes(size)


def assert_padded(received: bytes, data: bytes) -> None:
    assert received[: len(data)] == data
    tail = received[len(data) :]
    assert tail == bytes([SUB]) * len(tail)
    assert len(tail) < 128


def spawn(args: list[str], cwd: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        args, cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )


RunResult = tuple[int, bytes, list[bytes]]


def run_peer(args: list[str], cwd: Path, end: End) -> RunResult:
    """Run ``end`` against an lrzsz program; its return code, stderr and our writes."""
    proc = spawn(args, cwd)
    assert proc.stdin is not None and proc.stdout is not None
    writes: list[bytes] = []
    try:
        pump(end, proc.stdout.fileno(), proc.stdin.fileno(), writes=writes)
        _, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
    return proc.returncode, err, writes


def from_sx(args: list[str], cwd: Path, data: bytes, receiver: XmodemReceiver) -> RunResult:
    (cwd / "in.bin").write_bytes(data)
    return run_peer(["sx", "-X", "-q", *args, "in.bin"], cwd, receiver)


@dataclass
class RxRun:
    sender: XmodemSender
    writes: list[bytes]
    returncode: int
    file: bytes
    stderr: bytes


def send_to_rx(mode: str, size: int, workdir: Path) -> RxRun:
    workdir.mkdir()
    args = ["rx", "-X", "-q"] + ([] if mode == "checksum" else ["-c"]) + ["out.bin"]
    sender = XmodemSender(payload(size), one_k=mode == "1k")
    code, err, writes = run_peer(args, workdir, sender)
    return RxRun(sender, writes, code, (workdir / "out.bin").read_bytes(), err)


@pytest.fixture(scope="module")
def rx_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, int], RxRun]:
    base = tmp_path_factory.mktemp("rx")
    jobs = [(mode, size) for mode in MODES for size in SIZES]
    with ThreadPoolExecutor(max_workers=len(jobs)) as pool:
        futures = {(m, n): pool.submit(send_to_rx, m, n, base / f"{m}-{n}") for m, n in jobs}
        return {key: f.result() for key, f in futures.items()}


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("mode", MODES)
def test_xmodem_our_sender_to_lrzsz_rx(
    rx_runs: dict[tuple[str, int], RxRun], mode: str, size: int
) -> None:
    run = rx_runs[mode, size]
    assert run.sender.ok, (run.sender.error, run.stderr)
    assert run.returncode == 0, run.stderr
    assert run.sender.crc is (mode != "checksum")
    assert_padded(run.file, payload(size))
    starts = {w[0] for w in run.writes if w[0] in (SOH, STX)}
    if mode == "1k" and size > 7 * 128:
        assert STX in starts
    else:
        assert starts == {SOH}


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("mode", MODES)
def test_xmodem_lrzsz_sx_to_our_receiver(tmp_path: Path, mode: str, size: int) -> None:
    data = payload(size)
    receiver = XmodemReceiver(crc=mode != "checksum")
    code, err, writes = from_sx(["-k"] if mode == "1k" else [], tmp_path, data, receiver)
    assert receiver.ok, (receiver.error, err)
    assert code == 0, err
    assert receiver.crc is (mode != "checksum")
    assert_padded(receiver.data, data)
    acks = b"".join(writes).count(ACK)  # one per block, one for the (second) EOT
    if mode == "1k":
        assert acks <= size // 1024 + 8 + 1  # 1K blocks, perhaps a 128-byte tail
    else:
        assert acks == -(-size // 128) + 1


def test_xmodem_empty_file_both_ways(tmp_path: Path) -> None:
    receiver = XmodemReceiver()
    code, _, _ = from_sx([], tmp_path, b"", receiver)
    assert receiver.ok and receiver.data == b"" and code == 0
    run = send_to_rx("crc", 0, tmp_path / "rx")
    assert run.sender.ok and run.returncode == 0 and run.file == b""


def test_xmodem_sx_cancelled_by_our_receiver(tmp_path: Path) -> None:
    receiver = XmodemReceiver(max_size=10_000)
    code, _, _ = from_sx([], tmp_path, payload(50_000), receiver)
    assert not receiver.ok and receiver.data == b""
    assert receiver.error == "more data than max_size (10000 bytes)"
    assert code != 0
