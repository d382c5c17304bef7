"""``sondalog term`` local commands (issue 16, item 5): ``:help``, ``:log FILE``, ``:explain``,
and lines the logger cannot receive, against a served logger over TCP."""

from __future__ import annotations

import os
import pty
import re
import select
import subprocess
import sys
import time
from pathlib import Path

import pytest
from ala1_served import ServedLogger

from sondalog.app.explain import HELP, explain
from sondalog.app.virtual import VirtualLogger

TERM = [sys.executable, "-m", "sondalog", "term"]


def term(served: ServedLogger, script: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*TERM, served.url, "--timeout", "5"],
        input=script,
        capture_output=True,
        text=True,
        timeout=30,
    )


def help_examples() -> list[str]:
    """The example command lines of :data:`HELP` (two spaces, a command, two+ spaces)."""
    found = []
    for line in HELP.splitlines():
        match = re.match(r"  ((?:read|write|sum) .*?)(?:\s{2,}|$)", line)
        if match:
            found.append(match.group(1))
    return found


def test_help_lists_local_commands_and_its_examples_work(shared_logger: ServedLogger) -> None:
    examples = help_examples()
    assert len(examples) >= 10
    done = term(shared_logger, ":help\n" + "".join(f"{line}\n" for line in examples))
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(HELP)
    assert "\nERROR\n" not in done.stdout  # every example is a line the logger accepts
    assert done.stdout.count("OK\n") == len(examples)


@pytest.mark.parametrize(
    ("line", "token", "says"),
    [
        ("write channel 1 name Teplota vzduchu", "vzduchu", "a string needs a boundary"),
        ("write channel 1 name /Air temp/", "temp/", "not `read text /hi there/`"),
        ("write channel 123 name /x/", "123", "a channel list is `1 3 4` or `010304`"),
        ("write date 2026113", "2026113", "fills from the left"),
        ("write date 2026013012", "2026013012", "10 digits are read as MMDDhhmmss"),
        ("read channel 1 nme", "nme", "expected one of address, average"),
        ("reed date", "reed", "expected read, write or a header keyword"),
        ("write com speed 1234", "1234", "1234 is not one of"),
        ("write global reset read date", "read", "nothing may follow `write global reset`"),
        ("write channel 1 3 13 name /a/", "13", "channel 13: this logger has channels 1..12"),
    ],
)
def test_explain_names_the_rejected_token(
    shared_logger: ServedLogger, line: str, token: str, says: str
) -> None:
    done = term(shared_logger, f"{line}\n:explain\n")
    assert done.returncode == 1, done.stderr  # a refused line (issue 26)
    echo, error, shown, caret, message = done.stdout.splitlines()[:5]
    assert (echo, error) == (line, "ERROR")  # the logger refused it (§3.3.1) ...
    assert shown == line
    column = line.index(token)
    assert caret == " " * column + "^" * len(token)  # ... and the caret is under the token
    assert message.startswith(f"{token!r} (column {column + 1}): ")
    assert says in message


def test_explain_of_an_accepted_line_and_with_nothing_refused(shared_logger: ServedLogger) -> None:
    done = term(shared_logger, ":explain\n:explain read text hi there\n")
    assert done.returncode == 0
    lines = done.stdout.splitlines()
    assert lines[0].startswith("nothing to explain yet")
    assert lines[2].startswith("the local parser (protocol 2.10) accepts this line")
    assert "took 't' as its boundary and reads 'here'" in done.stdout


def test_log_captures_the_session(shared_logger: ServedLogger, tmp_path: Path) -> None:
    log = tmp_path / "session.log"
    done = term(shared_logger, f":log {log}\nread i version\nreed\n:log\nread i device\n")
    assert done.returncode == 1 and "answered ERROR to 'reed'" in done.stderr
    assert done.stdout == (
        f"logging the session to {log}\n2.10\nOK\nreed\nERROR\nlog closed\nALA1\nOK\n"
    )
    assert log.read_text() == "> read i version\n2.10\nOK\n> reed\nreed\nERROR\n"


def test_text_the_logger_cannot_receive_is_not_sent(shared_logger: ServedLogger) -> None:
    done = term(
        shared_logger,
        "write channel 1 name /Teplota °C/\nwrite channel 1 name /Mereni č/\nread i version\n"
        ":bogus\n",
    )
    assert done.returncode == 2
    assert done.stdout.startswith("2.10\nOK\nunknown local command ':bogus'")
    first, second = done.stderr.splitlines()
    assert "column 31: '°' (DEGREE SIGN) cannot be sent" in first
    assert "column 30: 'č' (LATIN SMALL LETTER C WITH CARON)" in second
    assert "write 'c' instead" in second


@pytest.mark.parametrize(
    "line",
    [
        "read i version",
        "read channel 1 3 value",
        "read channel 0102 name",
        "write channel 1 name/x/ format 5.2",
        "read text/a b/",
        "write text 5/abc/",
        "sum crcsum read channel name",
        "check 890 read date",
        "write date 1200",
        "read record 3 from date/2007/",
        "read channel 1 name 2 format",
        "write channel 1 sampling period 01",
    ],
)
def test_explain_accepts_what_the_logger_accepts(line: str) -> None:
    logger = VirtualLogger()
    try:
        assert logger.command(line).endswith("OK\r\n")
    finally:
        logger.close()
    assert explain(line).accepted, explain(line).render()


def _read_pty(fd: int, until: bytes, timeout: float = 10.0) -> bytes:
    deadline = time.monotonic() + timeout
    buf = b""
    while until not in buf:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out waiting for {until!r}; got {buf!r}"
        if select.select([fd], [], [], remaining)[0]:
            try:
                buf += os.read(fd, 65536)
            except OSError:
                break
    return buf


def test_local_commands_on_an_interactive_terminal(
    shared_logger: ServedLogger, tmp_path: Path
) -> None:
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
    log = tmp_path / "pty.log"
    try:
        assert b":help lists the local commands" in _read_pty(controller, b"ala1>")
        os.write(controller, f":log {log}\r".encode())
        _read_pty(controller, b"logging the session")
        os.write(controller, b"reed date\r")
        _read_pty(controller, b"(:explain tells which part the logger refused)")
        os.write(controller, b":explain\r")
        _read_pty(controller, b"expected read, write or a header keyword")
        os.write(controller, "read text/°/\r".encode())
        _read_pty(controller, b"(DEGREE SIGN) cannot be sent")
        os.write(controller, b":quit\r")
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(controller)
    assert log.read_text() == "> reed date\nreed date\nERROR\n"
