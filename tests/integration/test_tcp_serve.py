"""``sondalog logger serve`` over real TCP: lines per connection, line discipline, timers,
signals, identity of the state directory (issue 2 "Serving it")."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

from ala1_served import ServedLogger, exchange, read_quiet, read_until

Serve = Callable[..., ServedLogger]


def test_concurrent_clients_with_interleaved_partial_lines(shared_logger: ServedLogger) -> None:
    socks = [shared_logger.connect() for _ in range(6)]
    try:
        # Every client sends its command in three fragments, interleaved with the others'.
        fragments = [(b"read ", b"text/client-", f"{n}/\r".encode()) for n in range(len(socks))]
        for part in range(3):
            for sock, pieces in zip(socks, fragments, strict=True):
                sock.sendall(pieces[part])
            time.sleep(0.01)
        for n, sock in enumerate(socks):
            assert read_until(sock, b"OK\r\n") == f"client-{n}\r\nOK\r\n".encode()
        for sock in socks:
            assert read_quiet(sock, 0.05) == b""  # nobody got anybody else's answer
    finally:
        for sock in socks:
            sock.close()


def test_partial_line_of_a_closed_connection_does_not_leak(shared_logger: ServedLogger) -> None:
    first = shared_logger.connect()
    first.sendall(b"+read i ver")
    first.close()
    with shared_logger.connect() as second:
        assert exchange(second, b"sion\r", b"\r\n") == b"sion\r\nERROR\r\n"
        assert exchange(second, b"read i version\r", b"OK\r\n") == b"2.10\r\nOK\r\n"


def test_echo_backspace_and_escape(shared_logger: ServedLogger) -> None:
    with shared_logger.connect() as sock:
        # §3.4.2: `+` turns echo on; BS erases with BS space BS.
        got = exchange(sock, b"+read i vx\x08ersion\r", b"OK\r\n")
        assert got == b"+read i vx\x08 \x08ersion\r\n2.10\r\nOK\r\n"
        # §3.4.3: ESC discards the partial command; with echo on the module sends BREAK.
        got = exchange(sock, b"+read da\x1b", b"BREAK\r\n")
        assert got == b"+read da\r\nBREAK\r\n"
        # Without echo ESC discards silently; the next command starts clean.
        assert exchange(sock, b"read da\x1bread i version\r", b"OK\r\n") == b"2.10\r\nOK\r\n"
        # DEL erases silently without echo.
        assert exchange(sock, b"read i versionn\x7f\r", b"OK\r\n") == b"2.10\r\nOK\r\n"
        # CRLF and LFCR are one end; an empty line gets nothing.
        assert exchange(sock, b"\r\n\n\rread i version\n\r", b"OK\r\n") == b"2.10\r\nOK\r\n"
        assert read_quiet(sock, 0.05) == b""


def test_speed_runs_the_module_clock_faster(serve: Serve) -> None:
    served = serve("--speed", "200")
    with served.connect() as sock:
        assert exchange(sock, b"write date 20200101000000\r", b"OK\r\n") == b"OK\r\n"
        start = time.monotonic()
        time.sleep(0.1)
        got = exchange(sock, b"read date\r", b"OK\r\n")
        wall = time.monotonic() - start
    module = datetime.strptime(got.split(b"\r\n")[0].decode(), "%Y%m%d%H%M%S")
    elapsed = (module - datetime(2020, 1, 1)).total_seconds()
    assert elapsed >= 15  # at least 0.1 s * 200 = 20 s, minus rounding to whole seconds
    assert elapsed <= wall * 200 + 2


def test_timers_pause_reaches_its_own_line(serve: Serve) -> None:
    """§8.5.1: the paused answer comes from the timer task, to its sender only. ``pause``
    is line time: at ``--speed 100`` it still lasts real seconds (decisions "Time base");
    the entry timeout's own timer is tested on a stepped clock (test_line_discipline)."""
    served = serve("--speed", "100")
    with served.connect() as waiting, served.connect() as other:
        waiting.sendall(b"pause 1 read text/late/\r")
        assert exchange(other, b"read text/now/\r", b"OK\r\n") == b"now\r\nOK\r\n"
        assert read_quiet(waiting, 0.5) == b""  # not 1/100 of a second
        assert read_until(waiting, b"OK\r\n", timeout=5) == b"late\r\nOK\r\n"
        assert read_quiet(other, 0.05) == b""


def test_sigterm_and_sigint_stop_cleanly(serve: Serve, tmp_path: Path) -> None:
    for signum, name in ((signal.SIGTERM, "term"), (signal.SIGINT, "int")):
        served = serve(state=tmp_path / name)
        with served.connect() as sock:
            sock.sendall(b"read i ver")  # a partial line must not block the shutdown
            assert served.signal(signum) == 0
            assert read_quiet(sock, 0.5) == b""
        assert "Traceback" not in served.stderr()


def _serve_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sondalog", "logger", "serve", *args],
        capture_output=True,
        text=True,
        timeout=30,
    )


def test_protocol_and_serial_number_are_fixed_by_the_state(serve: Serve, tmp_path: Path) -> None:
    state = tmp_path / "v116"
    served = serve("--protocol", "1.16", "--serial-number", "A0042", state=state)
    with served.connect() as sock:
        got = exchange(sock, b"read i version read i snumber\r", b"OK\r\n")
        assert got == b"1.16\r\nA0042\r\nOK\r\n"
    assert served.signal(signal.SIGTERM) == 0
    refused = _serve_cli("--listen", "127.0.0.1:0", "--state", str(state), "--protocol", "2.10")
    assert refused.returncode == 2
    assert "protocol 1.16" in refused.stderr and refused.stdout == ""
    refused = _serve_cli("--listen", "127.0.0.1:0", "--state", str(state), "--serial-number", "B")
    assert refused.returncode == 2 and "serial number A0042" in refused.stderr
    again = serve(state=state)  # no options: whatever the state says
    with again.connect() as sock:
        assert exchange(sock, b"read i version\r", b"OK\r\n") == b"1.16\r\nOK\r\n"


def test_bad_options_exit_2(tmp_path: Path) -> None:
    state = str(tmp_path / "s")
    for args in (
        ["--listen", "127.0.0.1"],
        ["--listen", "127.0.0.1:99999"],
        ["--protocol", "3.0"],
        ["--speed", "0"],
        ["--speed", "fast"],
        ["--serial-number", "has space"],
    ):
        done = _serve_cli("--state", state, *args)
        assert done.returncode == 2, args
        assert "Error" in done.stderr and "Traceback" not in done.stderr
