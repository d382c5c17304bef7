"""Conversion tables end to end (issue 4): ``sondalog logger tables push|pull|check`` against
a served logger, the manual's example tables used by a type-3 and a type-9 channel, and real
XMODEM peers (lrzsz ``sx``/``rx``) talking to the logger over TCP."""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from ala1_served import ServedLogger, exchange

Serve = Callable[..., ServedLogger]
CLI = [sys.executable, "-m", "sondalog", "logger", "tables"]
TABLE1 = b"100.8 550.9\n351.65 1000\n893 1790.53\n"  # §10.2, 36 bytes
TABLE2 = b"3\n100.8 550.9\n351.65 1000\n893 1790.53\n4\n100.7 560\n351 1008\n890 1800.2\n"
SITE = """
[logger]
[[logger.analog]]
address = 16
signal = { model = "constant", value = 0.5 }
[[logger.analog]]
address = 17
signal = { model = "constant", value = 0.8 }
"""


def ask(served: ServedLogger, command: str) -> str:
    """The data lines of a successful command (an error times out the exchange)."""
    with served.connect() as sock:
        answer = exchange(sock, command.encode() + b"\r", b"OK\r\n").decode()
    return answer[: -len("OK\r\n")]


def tables_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "tables"
    folder.mkdir()
    (folder / "tabulka1.txt").write_bytes(TABLE1)
    (folder / "tabulka2.txt").write_bytes(TABLE2)
    return folder


def logger_with_tables(serve: Serve, tmp_path: Path) -> ServedLogger:
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    served = serve("--site", str(site))
    for command in (
        "write file record size 983040 write file list size 256 write file data size 51200",
        "write channel max number 2",
        "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
        "write channel 1 cal2 mult 1000 write channel 1 format 0.2",
        "write channel 1 convert file name/tabulka1/",
        "write channel 2 type 9 write channel 2 format 0.2 write channel 2 cal2 mult all 1000 4",
        "write channel 2 device all 1,1 write channel 2 address all 16,17",
        "write channel 2 switch output all 0,0 write channel 2 convert 1 file name/tabulka2/",
    ):
        assert ask(served, command) == "", command
    return served


def adc(volts: float) -> float:
    return round(volts / 2.5 * 4095) / 4095 * 2.5


def test_push_the_manual_tables_and_use_them(serve: Serve, tmp_path: Path) -> None:
    served = logger_with_tables(serve, tmp_path)
    url = f"tcp://127.0.0.1:{served.port}"
    done = subprocess.run([*CLI, "push", str(tables_dir(tmp_path)), url], capture_output=True)
    assert done.returncode == 0, done.stderr
    assert b"pushed 2 tables (24 bytes list, 106 bytes data), verified" in done.stdout
    assert done.stderr == b""  # no progress bar off a terminal, not even a blank line
    x = adc(0.5) * 1000  # channel 1: mV through tabulka1, between its rows 2 and 3
    one = 1000 + (1790.53 - 1000) * (x - 351.65) / (893 - 351.65)
    p = adc(0.8) * 4  # channel 2: parameter 3.2 between the regions 3 and 4 of tabulka2
    r3 = 1000 + (1790.53 - 1000) * (x - 351.65) / (893 - 351.65)
    r4 = 1008 + (1800.2 - 1008) * (x - 351) / (890 - 351)
    two = r3 + (r4 - r3) * (p - 3)
    assert ask(served, "read channel value") == f"{one:.2f},{two:.2f}\r\n"
    check = subprocess.run([*CLI, "check", url], capture_output=True, text=True)
    assert check.returncode == 0
    assert "channel 1 table 1 'tabulka1': ok" in check.stdout
    assert "channel 2 table 1 'tabulka2': ok" in check.stdout


def test_pull_round_trip_and_check_explains_a_bad_channel(serve: Serve, tmp_path: Path) -> None:
    served = logger_with_tables(serve, tmp_path)
    url = f"tcp://127.0.0.1:{served.port}"
    assert subprocess.run([*CLI, "push", str(tables_dir(tmp_path)), url]).returncode == 0
    out = tmp_path / "pulled"
    pulled = subprocess.run([*CLI, "pull", url, str(out)], capture_output=True)
    assert pulled.returncode == 0 and pulled.stderr == b"", pulled.stderr
    assert (out / "tabulka1.txt").read_bytes() == TABLE1
    assert (out / "tabulka2.txt").read_bytes() == TABLE2
    assert ask(served, "write channel 1 convert file name/tabulka2/") == ""
    assert ask(served, "write channel 2 convert 2 file name/nosuch/") == ""
    check = subprocess.run([*CLI, "check", url], capture_output=True, text=True)
    assert check.returncode == 1
    assert "channel 1 table 1 'tabulka2': no value: the channel needs a 1-D table" in check.stdout
    assert "channel 2 table 2 'nosuch': no value: no such table in the logger" in check.stdout
    assert ask(served, "read channel value").startswith(",")  # channel 1 has no value


@pytest.mark.parametrize(
    ("files", "message"),
    [
        ({"t1.txt": b"1 2\n1 3\n"}, "inputs must ascend"),
        ({"t1.txt": b"1 2\nx 3\n"}, "not a number"),
        ({"muchtoolongname.txt": TABLE1}, "1 to 10 characters"),
        ({"big.txt": b"".join(b"%d 1\n" % i for i in range(20000))}, "file data size"),
    ],
)
def test_push_refuses_bad_tables_and_sends_nothing(
    serve: Serve, tmp_path: Path, files: dict[str, bytes], message: str
) -> None:
    served = logger_with_tables(serve, tmp_path)
    folder = tmp_path / "bad"
    folder.mkdir()
    for name, body in files.items():
        (folder / name).write_bytes(body)
    url = f"tcp://127.0.0.1:{served.port}"
    done = subprocess.run([*CLI, "push", str(folder), url], capture_output=True, text=True)
    assert done.returncode == 2
    assert message in done.stderr
    check = subprocess.run([*CLI, "check", url], capture_output=True, text=True)
    assert "no such table" in check.stdout  # nothing was uploaded


def test_push_to_a_logger_without_a_partition_is_refused(serve: Serve, tmp_path: Path) -> None:
    served = serve()
    url = f"tcp://127.0.0.1:{served.port}"
    done = subprocess.run(
        [*CLI, "push", str(tables_dir(tmp_path)), url], capture_output=True, text=True
    )
    assert done.returncode == 2
    assert "file list size is 0" in done.stderr


@pytest.mark.skipif(shutil.which("sx") is None, reason="lrzsz not installed")
@pytest.mark.parametrize("flags", [[], ["-k"]])
def test_sx_uploads_a_table_list_to_the_logger(
    serve: Serve, tmp_path: Path, flags: list[str]
) -> None:
    served = logger_with_tables(serve, tmp_path)
    listing = tmp_path / "list"
    listing.write_bytes(b"tabulka1 36\n")
    with served.connect() as sock:
        sock.setblocking(True)  # the peer program reads the socket itself
        sock.sendall(b"write special file list xmodem\r")
        done = subprocess.run(
            ["sx", *flags, str(listing)], stdin=sock, stdout=sock, capture_output=False,
            stderr=subprocess.PIPE, timeout=60,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr  # (sx reads the logger's OK itself)
    with served.connect() as sock:
        sock.setblocking(True)
        sock.sendall(b"read special file list xmodem\r")
        received = tmp_path / "got"
        done = subprocess.run(
            ["rx", "-c", received.name],
            stdin=sock,
            stdout=sock,
            stderr=subprocess.PIPE,
            timeout=60,
            cwd=tmp_path,
        )  # fmt: skip  (restricted rx refuses absolute paths)
        assert done.returncode == 0, done.stderr
        assert received.read_bytes().rstrip(b"\x1a") == b"tabulka1 36\n"
