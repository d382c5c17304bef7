"""Issue 20: input received while a command waits in ``pause`` (§8.5.1) is held in a bounded
backlog. §6.11.1 forbids sending during a command; what comes beyond
:data:`~sondalog.ala1.lines.BACKLOG_MAX` is lost, as in a FIFO overrun, and the command line
it belonged to gets the error response instead of running with a piece missing."""

from __future__ import annotations

from ala1_module import Module

from sondalog.ala1.lines import BACKLOG_MAX

VERSION = b"2.10\r\nOK\r\n"
COMMAND = b"read i version\r"
CHUNK = COMMAND * 4096  # 60 KiB, a transport's read


def backlog(module: Module) -> int:
    return len(module.engine._lines[module.line].backlog)


def test_a_flood_during_pause_keeps_a_bounded_backlog(module: Module) -> None:
    assert module.engine.input_room(module.line) is None  # nothing waits: no bound
    assert module.ask("pause 3599 read i version") == b""
    assert module.engine.input_room(module.line) == BACKLOG_MAX
    for _ in range(64):  # 3.8 MB while the command waits
        assert module.feed(CHUNK) == b""
        assert backlog(module) <= BACKLOG_MAX
    assert module.engine.input_room(module.line) == 0
    answer = module.advance(3599)
    kept = BACKLOG_MAX // len(COMMAND)  # whole command lines that fit
    assert answer == VERSION * (1 + kept)  # the paused command, then each kept line
    # the line cut by the overrun ("r" kept, the rest lost) never runs: the error response
    partial = COMMAND[: BACKLOG_MAX % len(COMMAND)]
    assert module.feed(COMMAND) == partial + COMMAND[:-1] + b"\r\nERROR\r\n"
    assert module.feed(COMMAND) == VERSION  # and the line works as before
    assert backlog(module) == 0 and module.engine.input_room(module.line) is None


def test_a_flood_in_the_same_read_as_the_pause(module: Module) -> None:
    data = b"pause 2 read i version\r" + COMMAND * 2 + b"x" * (10 * BACKLOG_MAX)
    assert module.feed(data) == b""
    assert backlog(module) == BACKLOG_MAX
    assert module.advance(2) == VERSION * 3
    # the x... line lost its end: an error, whatever follows it on that line
    answer = module.feed(b"\r")
    assert answer.endswith(b"\r\nERROR\r\n") and answer.startswith(b"xxx")
    assert len(answer) == 120 + len(b"\r\nERROR\r\n")  # §3.4.1: its first 120 characters
    assert module.feed(COMMAND) == VERSION


def test_an_overrun_exactly_at_a_line_end_spoils_only_the_next_line(module: Module) -> None:
    assert module.ask("pause 1 read i version") == b""
    fits = COMMAND * (BACKLOG_MAX // len(COMMAND) - 1)
    filler = b"x" * (BACKLOG_MAX - len(fits) - 1) + b"\r"  # fills the backlog exactly
    assert module.feed(fits + filler + b"write i name/lost/\r") == b""
    assert module.engine.input_room(module.line) == 0
    answer = module.advance(1)
    assert answer == VERSION * (1 + len(fits) // len(COMMAND)) + filler + b"\nERROR\r\n"
    # the lost write never ran, and the next line (which may be its remainder) is refused
    assert module.feed(b"/\r") == b"/\r\nERROR\r\n"
    assert module.ask("read i name") == b"\r\nOK\r\n"


def test_a_second_pause_in_the_backlog_keeps_the_loss_after_it(module: Module) -> None:
    assert module.ask("pause 1 read i version") == b""
    data = b"pause 1 read i version\r" + COMMAND * 300 + b"write i name/lost/\r"
    assert module.feed(data) == b""
    assert module.advance(1) == VERSION  # the first; the second now waits
    assert module.engine.input_room(module.line) == 0  # nothing may follow the loss
    assert module.feed(COMMAND) == b""
    kept = data[:BACKLOG_MAX]
    assert module.advance(1) == VERSION * kept.count(b"\r")
    partial = kept[kept.rindex(b"\r") + 1 :]
    assert module.feed(COMMAND) == partial + COMMAND[:-1] + b"\r\nERROR\r\n"
    assert module.ask("read i name") == b"\r\nOK\r\n"
