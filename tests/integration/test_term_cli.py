"""``sondalog term``: scripted through stdin, and interactive on a pseudo-terminal."""

from __future__ import annotations

import contextlib
import os
import pty
import select
import subprocess
import sys
import time

from ala1_served import ServedLogger

TERM = [sys.executable, "-m", "sondalog", "term"]


def test_term_scripted_from_stdin(shared_logger: ServedLogger) -> None:
    script = (
        "read i version\n\nsum read i device\r\nreed date\nquiet read i version\nread i device\n"
    )
    done = subprocess.run(
        [*TERM, shared_logger.url, "--timeout", "2"],
        input=script,
        capture_output=True,
        text=True,
        timeout=30,
    )
    # every line is sent and answered; the refused one makes the exit status 1 (issue 26)
    assert done.returncode == 1, done.stderr
    assert done.stdout == ("2.10\nOK\n00255,ALA1\n00154,OK\nreed date\nERROR\n2.10\nALA1\nOK\n")
    assert done.stderr == "the logger answered ERROR to 'reed date' (:explain tells why)\n"


def test_term_exit_status_of_error_responses(shared_logger: ServedLogger) -> None:
    """Scripted, an ERROR answer (plain or decorated, §3.3.1) exits 1 unless --ignore-errors;
    a script that only gets OK exits 0."""

    def run(script: str, *args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [*TERM, shared_logger.url, "--timeout", "2", *args],
            input=script,
            capture_output=True,
            text=True,
            timeout=30,
        )

    assert run("read i version\nsum read i device\n").returncode == 0
    refused = run("sum write date 2026013012\nread i version\n")
    assert refused.returncode == 1
    assert refused.stdout.endswith("ERROR\n2.10\nOK\n")  # the next line still ran
    assert "answered ERROR to 'sum write date 2026013012'" in refused.stderr
    ignored = run("reed date\nread i version\n", "--ignore-errors")
    assert (ignored.returncode, ignored.stderr) == (0, "")
    assert ignored.stdout == "reed date\nERROR\n2.10\nOK\n"


def test_term_reports_no_answer(shared_logger: ServedLogger) -> None:
    done = subprocess.run(
        [*TERM, shared_logger.url, "--timeout", "0.2"],
        input="check 1 read date\nread i version\n",
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 1
    assert done.stdout == "2.10\nOK\n"
    assert "no answer to 'check 1 read date'" in done.stderr


def test_term_bad_url_and_refused_connection() -> None:
    done = subprocess.run([*TERM, "10001"], capture_output=True, text=True, timeout=30)
    assert done.returncode == 2 and "tcp://" in done.stderr
    done = subprocess.run(
        [*TERM, "tcp://127.0.0.1:1"], input="", capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 1 and "cannot connect" in done.stderr


def _read_pty(fd: int, until: bytes, timeout: float = 10.0) -> bytes:
    deadline = time.monotonic() + timeout
    buf = b""
    while until not in buf:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out waiting for {until!r}; got {buf!r}"
        ready, _, _ = select.select([fd], [], [], remaining)
        if ready:
            try:
                buf += os.read(fd, 65536)
            except OSError:
                break
    return buf


def test_term_interactive_on_a_pty(shared_logger: ServedLogger) -> None:
    controller, terminal = pty.openpty()
    proc = subprocess.Popen(
        [*TERM, shared_logger.url],
        stdin=terminal,
        stdout=terminal,
        stderr=terminal,
        env={**os.environ, "TERM": "xterm", "PROMPT_TOOLKIT_NO_CPR": "1"},
        close_fds=True,
    )
    os.close(terminal)
    try:
        _read_pty(controller, b"ala1>")
        os.write(controller, b"read text/hello from a pty/\r")
        _read_pty(controller, b"hello from a pty")
        os.write(controller, b"pause 0 read i device\r")
        _read_pty(controller, b"ALA1")
        # Ctrl-D quits. prompt_toolkit prints output with the terminal briefly in cooked mode,
        # where the tty itself would swallow a Ctrl-D typed in that instant: repeat it.
        for _ in range(50):
            os.write(controller, b"\x04")
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=0.2)
                break
        assert proc.wait(timeout=1) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(controller)
