"""``logger serve --pty``: a real pseudo-terminal line (§6.11.1 flow control, §6.11.2 speed,
§8.5.2 comspeed, §6.14.9.2 disconnects), opened by the host through its symlink."""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path

from ala1_served import ServedLogger
from pty_host import HostPort, answer_size, paced_seconds, text_lines

Serve = Callable[..., ServedLogger]


def _pty(serve: Serve, tmp_path: Path, *extra: str, name: str = "ala1") -> Path:
    link = tmp_path / name
    serve("--pty", str(link), *extra, state=tmp_path / f"state-{name}")
    assert link.is_symlink()
    return link


def test_pacing_within_two_percent_at_9600_and_115200(serve: Serve, tmp_path: Path) -> None:
    """About 21 kB each (200 pipelined ``read text`` lines); both lines run at once."""
    count = 200
    results: dict[int, tuple[float, float]] = {}
    errors: list[BaseException] = []

    def download(link: Path, baud: int) -> None:
        try:
            with HostPort(link, 9600) as host:
                if baud != 9600:
                    assert host.ask(f"write com speed {baud}".encode()) == b"OK\r\n"
                    host.set_speed(baud)
                host.write(text_lines(count))
                data, reads = host.read_timed(answer_size(count), timeout=60)
                assert data.endswith(b"R" * 100 + b"\r\nOK\r\n")  # the 200th line
                assert len(data) == answer_size(count)
                results[baud] = paced_seconds(reads, baud)
        except BaseException as exc:
            errors.append(exc)

    links = {baud: _pty(serve, tmp_path, name=f"ala1-{baud}") for baud in (9600, 115200)}
    threads = [threading.Thread(target=download, args=(links[b], b)) for b in links]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(90)
    assert not errors, errors
    for baud, (measured, theory) in results.items():
        assert theory > 1.5  # ~21 kB: 22 s at 9600, 1.8 s at 115200
        assert abs(measured - theory) <= 0.02 * theory, (baud, measured, theory)


def test_comspeed_paces_one_answer_then_returns(serve: Serve, tmp_path: Path) -> None:
    link = _pty(serve, tmp_path)
    with HostPort(link, 9600) as host:
        # the server notices a new host within 20 ms and reads its speed when bytes arrive
        assert host.ask(b"read i version") == b"2.10\r\nOK\r\n"
        host.write(b"comspeed 1200 read text/" + b"c" * 90 + b"/\r")  # 120 characters at most
        time.sleep(0.05)  # sent (tcdrain returns at once on a pty: the module reads later)
        host.set_speed(1200)  # the host follows the answer's rate ...
        data, reads = host.read_timed(b"OK\r\n", timeout=5)
        assert data == b"c" * 90 + b"\r\nOK\r\n"
        measured, theory = paced_seconds(reads, 1200)
        assert theory > 0.7 and abs(measured - theory) < 0.2 * theory
        host.set_speed(9600)  # ... and returns with it
        host.write(b"read text/" + b"d" * 100 + b"/\r")
        data, reads = host.read_timed(b"OK\r\n", timeout=5)
        assert data == b"d" * 100 + b"\r\nOK\r\n"
        start = reads[0][0]
        assert reads[-1][0] - start < 0.3  # 9600 again: ~0.1 s, not ~0.9 s


def test_written_com_speed_applies_after_its_ok(serve: Serve, tmp_path: Path) -> None:
    link = _pty(serve, tmp_path)
    with HostPort(link, 9600) as host:
        assert host.ask(b"write com speed 19200") == b"OK\r\n"  # sent at 9600
        host.set_speed(19200)
        host.write(text_lines(10))
        _, reads = host.read_timed(answer_size(10), timeout=5)
        measured, theory = paced_seconds(reads, 19200)
        assert abs(measured - theory) < 0.2 * theory + 0.02


def test_xoff_stops_output_and_xon_resumes(serve: Serve, tmp_path: Path) -> None:
    link = _pty(serve, tmp_path)
    with HostPort(link, 9600) as host:
        host.write(text_lines(20))  # 2120 bytes: 2.2 s at 9600
        before = host.read_until(300, timeout=5)
        host.write(b"\x13")
        while_stopped = host.read_quiet(0.1)  # what was on its way when XOFF arrived
        time.sleep(0.5)
        assert host.read_quiet(0.05) == b""  # stopped
        assert len(while_stopped) < 100
        host.write(b"\x11")
        resumed_at = time.monotonic()
        left = answer_size(20) - len(before) - len(while_stopped)
        rest, reads = host.read_timed(left, 10)
        assert before + while_stopped + rest == b"".join(
            bytes([65 + i % 26]) * 100 + b"\r\nOK\r\n" for i in range(20)
        )
        assert reads[0][0] - resumed_at < 0.2


def test_flow_control_keeps_real_time_at_a_fast_clock(serve: Serve, tmp_path: Path) -> None:
    """At ``--speed 100`` XOFF still holds the answer in real time (the 60 s override is line
    time, decisions "Time base"; the override itself is tested on a stepped clock in
    test_line_pacing); XON releases it."""
    link = _pty(serve, tmp_path, "--speed", "100")
    with HostPort(link, 9600) as host:
        host.write(b"\x13")
        host.write(b"read i version\r")
        assert host.read_quiet(1.0) == b""  # 0.6 s would be 60 s at the module's speed
        host.write(b"\x11")
        assert host.read_until(b"2.10\r\nOK\r\n", timeout=5)


def test_baud_mismatch_is_garbage_until_the_host_fixes_its_speed(
    serve: Serve, tmp_path: Path
) -> None:
    link = _pty(serve, tmp_path)
    with HostPort(link, 19200) as host:  # the module is at 9600
        host.write(b"read i version\r")
        assert host.read_quiet(0.5) == b""  # no line end arrives: no answer at all
        host.set_speed(9600)
        host.write(b"\r")  # ends the garbage: the error response
        garbage = host.read_until(b"\r\nERROR\r\n")
        text = garbage.removesuffix(b"\r\nERROR\r\n")
        assert len(text) == len(b"read i version\r") and all(b >= 0x80 for b in text)
        assert host.ask(b"read i version") == b"2.10\r\nOK\r\n"


def test_closing_the_pty_disconnects_the_line(serve: Serve, tmp_path: Path) -> None:
    link = _pty(serve, tmp_path)
    with HostPort(link) as host:
        host.write(b"read i")  # a partial command ...
        time.sleep(0.2)
    time.sleep(0.2)
    with HostPort(link) as host:  # ... is gone with the line: a new line starts empty
        host.write(b" version\r")
        assert host.read_until(b"ERROR\r\n") == b" version\r\nERROR\r\n"
        assert host.ask(b"read i version") == b"2.10\r\nOK\r\n"


def test_the_symlink_is_removed_on_exit(serve: Serve, tmp_path: Path) -> None:
    link = tmp_path / "gone"
    served = serve("--pty", str(link))
    assert link.is_symlink()
    assert served.signal(signal.SIGTERM) == 0
    assert not link.exists() and not link.is_symlink()


def _tcp_seconds(served: ServedLogger, count: int) -> float:
    """Seconds from sending ``count`` ``read text`` lines over TCP to the last answer byte."""
    with served.connect() as sock:
        start = time.monotonic()
        sock.sendall(text_lines(count))
        got = b""
        while len(got) < answer_size(count):
            got += sock.recv(65536)
        assert got.endswith(b"OK\r\n")
        return time.monotonic() - start


def test_line_rate_paces_tcp(serve: Serve, tmp_path: Path) -> None:
    assert _tcp_seconds(serve("--line-rate"), 10) > 0.9 * answer_size(10) * 10 / 9600  # 1.1 s


def test_tcp_without_line_rate_is_not_paced(serve: Serve) -> None:
    assert _tcp_seconds(serve(), 10) < 0.5
