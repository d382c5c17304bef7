"""``logger serve --serial DEVICE`` on one end of a ``socat`` pty pair, and the host tools
(client, ``sondalog term``) over ``serial://`` URLs."""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from ala1_served import ServedLogger
from pty_host import HostPort, answer_size, paced_seconds, text_lines

from sondalog.client import Client

Serve = Callable[..., ServedLogger]
SONDALOG = [sys.executable, "-m", "sondalog"]


@pytest.fixture
def socat_pair(tmp_path: Path) -> Iterator[tuple[Path, Path]]:
    """Two ptys joined by socat: what one end writes, the other reads (a null-modem cable)."""
    if shutil.which("socat") is None:
        pytest.skip("socat is not installed")
    a, b = tmp_path / "tty-a", tmp_path / "tty-b"
    proc = subprocess.Popen(
        ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 10
        while not (a.exists() and b.exists()):
            assert time.monotonic() < deadline and proc.poll() is None, "socat did not start"
            time.sleep(0.02)
        yield a, b
    finally:
        proc.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=5)
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_serial_line_is_paced_and_answers(
    serve: Serve, tmp_path: Path, socat_pair: tuple[Path, Path]
) -> None:
    device, host_end = socat_pair
    served = serve("--serial", str(device))
    with HostPort(host_end, 9600) as host:
        assert host.ask(b"read i version") == b"2.10\r\nOK\r\n"
        host.write(text_lines(10))
        data, reads = host.read_timed(answer_size(10), timeout=10)
        assert data.endswith(b"J" * 100 + b"\r\nOK\r\n")
        measured, theory = paced_seconds(reads, 9600)
        assert abs(measured - theory) < 0.2 * theory  # socat adds its own small delays
        host.write(b"comspeed 115200 read i version\r")  # the port switches and returns
        assert host.read_until(b"OK\r\n") == b"2.10\r\nOK\r\n"
        assert host.ask(b"read i version") == b"2.10\r\nOK\r\n"
    assert served.alive()


def test_serve_refuses_a_missing_serial_device(tmp_path: Path) -> None:
    missing = str(tmp_path / "nothing")
    done = subprocess.run(
        [*SONDALOG, "logger", "serve", "--listen", "127.0.0.1:0", "--serial", missing],
        cwd=tmp_path,  # the default state directory goes there
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 1 and "cannot open the lines" in done.stderr


def test_client_and_term_over_a_pty_url(serve: Serve, tmp_path: Path) -> None:
    link = tmp_path / "ala1"
    serve("--pty", str(link))
    with Client(f"serial://{link}?baud=9600", timeout=3) as logger:
        assert logger.command("read i version").lines == ("2.10",)
    done = subprocess.run(
        [*SONDALOG, "term", f"serial://{link}"],
        input="read i version\n",
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 0 and done.stdout == "2.10\nOK\n", done.stderr


def test_client_at_the_wrong_baud_gets_no_answer(serve: Serve, tmp_path: Path) -> None:
    link = tmp_path / "ala1"
    serve("--pty", str(link))
    done = subprocess.run(
        [*SONDALOG, "term", "--timeout", "0.5", f"serial://{link}?baud=19200"],
        input="read i version\n",
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 1 and done.stdout == "" and "no answer" in done.stderr
