"""``sondalog bus`` at the wrong peer, or with a command the module will not answer (issue 16,
item 2): real ``bus serve`` and ``logger serve`` subprocesses over TCP."""

from __future__ import annotations

import os
import pty
import select
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from bus_helpers import ServedBus, sondalog

SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]


@pytest.fixture
def logger_url(tmp_path: Path) -> Iterator[str]:
    """A served ALA1 logger: a peer that answers, but not in HCTMPS1 frames."""
    proc = subprocess.Popen(
        [*SERVE, "--listen", "127.0.0.1:0", "--state", str(tmp_path / "logger")],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 20)
    line = proc.stdout.readline().decode() if ready else ""
    try:
        assert line.startswith("listening on "), line
        yield "tcp://" + line.removeprefix("listening on ").strip()
    finally:
        proc.kill()
        proc.wait(timeout=10)
        proc.stdout.close()


@pytest.fixture(scope="module")
def bus_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with ServedBus(tmp_path_factory.mktemp("bus") / "state") as served:
        yield served.url


def test_scan_at_a_logger_says_so_after_one_round(logger_url: str) -> None:
    done = sondalog("-v", "bus", "scan", logger_url)
    assert done.returncode == 1
    assert "the peer answers, but not with HCTMPS1 frames" in done.stderr
    assert "ERROR" in done.stderr  # what it sent is shown
    assert f"Is this an ALA1 logger? Talk to it with: sondalog term {logger_url}" in done.stderr
    assert "scan round 1/30" in done.stderr
    assert "scan round 2/" not in done.stderr  # said after the first round, not after 30


def test_term_at_the_bus_says_so_and_names_bus_scan(bus_url: str) -> None:
    """The reverse mistake (issue 26): ``term`` at the bus used to say only "no answer"."""
    done = subprocess.run(
        [sys.executable, "-m", "sondalog", "term", bus_url, "--timeout", "0.5"],
        input="read i version\n",
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert "no answer to 'read i version'" in done.stderr
    assert f"{bus_url} is an HCTMPS1 bus, not an ALA1 logger: modules H1, T1 answered HELLO" in (
        done.stderr
    )
    assert f"Talk to it with: sondalog bus scan {bus_url}" in done.stderr


def test_term_at_the_bus_interactive_hints_at_bus_scan(bus_url: str) -> None:
    controller, terminal = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "term", bus_url, "--timeout", "0.5"],
        stdin=terminal,
        stdout=terminal,
        stderr=terminal,
        env={**os.environ, "TERM": "xterm", "PROMPT_TOOLKIT_NO_CPR": "1"},
        close_fds=True,
    )
    os.close(terminal)
    seen = b""
    try:
        seen += _read_pty(controller, b"ala1>")
        os.write(controller, b"read i version\r")
        seen += _read_pty(controller, b"Try: sondalog bus scan")
        os.write(controller, b":quit\r")
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(controller)
    assert b"an ALA1 logger answers every line (OK or ERROR)" in seen


def _read_pty(fd: int, until: bytes, timeout: float = 20.0) -> bytes:
    """What the terminal showed until ``until`` (its line breaks undone)."""
    deadline = time.monotonic() + timeout
    buf = b""
    while until not in buf.replace(b"\r\n", b""):
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out waiting for {until!r}; got {buf!r}"
        if select.select([fd], [], [], remaining)[0]:
            try:
                buf += os.read(fd, 65536)
            except OSError:
                break
    return buf.replace(b"\r\n", b"")


def test_scan_logs_one_line_per_round(bus_url: str) -> None:
    done = sondalog("-v", "bus", "scan", bus_url)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [
        "H1", "HCTMPS1-hum", "server", "(SHT11)", "T1", "HCTMPS1-temp", "server", "(DS18B20)"
    ]  # fmt: skip
    rounds = [line for line in done.stderr.splitlines() if "scan round" in line]
    assert len(rounds) >= 2  # the last round finds nothing new
    # one line a round, numbered; broadcast replies may collide, so a module can come in a
    # later round: the modules found so far only grow, and the last line holds both
    assert rounds[0].split(": HELLO")[0].endswith("scan round 1/30")
    both = repr({"T1": "HCTMPS1-temp server (DS18B20)", "H1": "HCTMPS1-hum server (SHT11)"})
    swapped = repr({"H1": "HCTMPS1-hum server (SHT11)", "T1": "HCTMPS1-temp server (DS18B20)"})
    assert rounds[-1].endswith(both) or rounds[-1].endswith(swapped)
    assert rounds[-1].split(": HELLO")[0].endswith(f"scan round {len(rounds)}/30")


def test_a_connect_command_without_connect_says_what_it_needs(bus_url: str) -> None:
    done = sondalog("bus", "ask", bus_url, "T1", "LISTSUP", "--timeout", "0.3", "--host-id", "A1")
    assert done.returncode == 1
    assert "no reply from T1 to LISTSUP: LISTSUP is answered only inside <connect>" in done.stderr
    assert "sondalog bus ask URL T1 CONNECT PASSWORD" in done.stderr
    assert "--host-id (A1)" in done.stderr
    opened = sondalog("bus", "ask", bus_url, "T1", "CONNECT", "0000", "--host-id", "A1")
    assert opened.stdout == "RCONNECT.<OK>\n"
    listed = sondalog("bus", "ask", bus_url, "T1", "LISTSUP", "--host-id", "A1")
    assert listed.stdout == "RLISTSUP.<EMPTY>\n"  # the context outlives the process
    sondalog("bus", "ask", bus_url, "T1", "DISCONNECT", "--host-id", "A1")


def test_lower_case_and_unknown_commands_and_absent_modules(bus_url: str) -> None:
    lower = sondalog("bus", "ask", bus_url, "T1", "pv")
    assert lower.returncode == 2
    assert "'pv': HCTMPS1 commands are upper case" in lower.stderr and ": PV" in lower.stderr
    unknown = sondalog("bus", "ask", bus_url, "T1", "WEATHER", "--timeout", "0.3")
    assert unknown.returncode == 1
    assert "a module ignores commands it does not know; the commands are ADDP," in unknown.stderr
    absent = sondalog("bus", "ask", bus_url, "T9", "PV", "--timeout", "0.3")
    assert absent.returncode == 1
    assert "no reply from T9 to PV, nor to HELLO: is T9 on this bus?" in absent.stderr
    wrong = sondalog("bus", "ask", bus_url, "H1", "CONNECT", "nope", "--timeout", "0.3")
    assert wrong.returncode == 1 and "a wrong password gets none" in wrong.stderr
