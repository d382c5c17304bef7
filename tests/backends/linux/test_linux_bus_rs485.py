"""The HCTMPS1 bus on an RS-485 adapter, end to end: ``sondalog serve`` with ``[bus.serve]
serial`` + ``rs485 = "auto"`` on one end of a pty pair (socat), a module measuring a DS18B20
of a fake w1 sysfs tree (``SONDALOG_ROOT``), and the bus master on the other end through
``serial://...?rs485=auto``: scan, then PV follows the real sensor."""

from __future__ import annotations

import asyncio
import os
import select
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from linux_fakesys import FakeW1

from sondalog.client.bus import BusMaster

SLAVE = "28-000008d5e4fd"


@pytest.fixture
def pty_pair(tmp_path: Path) -> Iterator[tuple[Path, Path]]:
    """Two ptys wired back to back, as two RS-485 adapters on one pair of wires."""
    if shutil.which("socat") is None:
        pytest.skip("socat is not installed")
    a, b = tmp_path / "adapter-a", tmp_path / "adapter-b"
    proc = subprocess.Popen(
        ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 5
    while not (a.exists() and b.exists()):
        assert time.monotonic() < deadline, "socat made no ptys"
        time.sleep(0.02)
    yield a, b
    proc.terminate()
    proc.wait(5)


def _serve(site: Path, state: Path, root: Path) -> subprocess.Popen[bytes]:
    env = {**os.environ, "SONDALOG_ROOT": str(root)}
    return subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(state)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )


def _line(proc: subprocess.Popen[bytes], pending: bytearray) -> str:
    """The next line serve prints (read from the pipe's descriptor: no hidden buffer)."""
    assert proc.stdout is not None
    fd = proc.stdout.fileno()
    while b"\n" not in pending:
        ready, _, _ = select.select([fd], [], [], 20)
        assert ready, "serve printed nothing"
        data = os.read(fd, 4096)
        assert data, proc.stderr.read().decode() if proc.stderr else ""
        pending += data
    line, _, rest = bytes(pending).partition(b"\n")
    pending[:] = rest
    return line.decode().strip()


def _site(tmp_path: Path, serve: str) -> Path:
    site = tmp_path / "site.toml"
    site.write_text(
        f"""
[bus]
baud = 9600

[[bus.modules]]
id = "T1"
kind = "temp"
cycle = 1.0
source = "w1:{SLAVE}"

[bus.serve]
listen = "127.0.0.1:0"
{serve}
"""
    )
    return site


async def _pv_until(master: BusMaster, expected: float, limit: float = 10.0) -> float:
    deadline = time.monotonic() + limit
    value = await master.pv("T1")
    while value != pytest.approx(expected) and time.monotonic() < deadline:
        await asyncio.sleep(0.3)
        value = await master.pv("T1")
    return value


def test_a_module_with_a_real_ds18b20_on_an_rs485_adapter(
    tmp_path: Path, pty_pair: tuple[Path, Path]
) -> None:
    adapter_a, adapter_b = pty_pair
    root = tmp_path / "root"
    w1 = FakeW1(root, bulk=False)
    w1.sensor(SLAVE, 23.5)
    site = _site(tmp_path, f'serial = "{adapter_a}"\nrs485 = "auto"')
    proc = _serve(site, tmp_path / "state", root)
    try:
        pending = bytearray()
        assert _line(proc, pending).startswith("bus listening on 127.0.0.1:")
        assert _line(proc, pending) == f"bus RS-485 (auto) on {adapter_a}"

        async def master_side() -> tuple[dict[str, str], float, float]:
            master = await BusMaster.open(f"serial://{adapter_b}?baud=9600&rs485=auto")
            try:
                found = await master.scan()
                first = await _pv_until(master, 23.5)
                w1.set(SLAVE, -4.0625)  # the sensor cools down
                second = await _pv_until(master, -4.06)
                return found, first, second
            finally:
                await master.close()

        found, first, second = asyncio.run(master_side())
        assert list(found) == ["T1"]
        assert first == pytest.approx(23.5)
        assert second == pytest.approx(-4.06)
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0


def test_a_port_that_cannot_do_the_mode_is_a_site_error(
    tmp_path: Path, pty_pair: tuple[Path, Path]
) -> None:
    adapter_a, _ = pty_pair
    root = tmp_path / "root"
    FakeW1(root, bulk=False).sensor(SLAVE, 20.0)
    site = _site(tmp_path, f'serial = "{adapter_a}"\nrs485 = "kernel"')
    proc = _serve(site, tmp_path / "state", root)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2
    text = err.decode()
    assert "bus.serve.rs485" in text and "kernel RS-485 mode not supported" in text
    assert "use mode = 'rts' or 'auto'" in text


def test_bus_serve_on_an_rs485_adapter(tmp_path: Path, pty_pair: tuple[Path, Path]) -> None:
    adapter_a, adapter_b = pty_pair
    command = [sys.executable, "-m", "sondalog", "bus", "serve", "--listen", "127.0.0.1:0"]
    state = ["--state", str(tmp_path / "state")]
    refused = subprocess.run([*command, *state, "--rs485", "auto"], capture_output=True, timeout=20)
    assert refused.returncode == 2 and b"--rs485 needs the adapter" in refused.stderr
    refused = subprocess.run(
        [*command, *state, "--serial", str(adapter_a), "--rs485", "rts"],
        capture_output=True,
        timeout=20,
    )
    assert refused.returncode == 2 and b"no RTS line" in refused.stderr
    proc = subprocess.Popen(
        [*command, *state, "--serial", str(adapter_a), "--rs485", "auto"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        assert _line(proc, bytearray()).startswith("listening on 127.0.0.1:")

        async def hello() -> str:
            master = await BusMaster.open(f"serial://{adapter_b}?rs485=auto")
            try:
                return await master.hello("H1")
            finally:
                await master.close()

        assert asyncio.run(hello()).startswith("HCTMPS1")
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0
