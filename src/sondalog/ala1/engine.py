"""The ALA1 engine: a pure, sans-I/O core (DESIGN.md point 1).

Transports feed it received bytes with the current clock time and send what it returns; they
wake it at :meth:`Engine.next_deadline` by calling :meth:`Engine.advance`. Each line (a TCP
connection, a serial port) has its own line state (§3.4 and spec notes §1): echo, partial
command, entry timeout, a command waiting for its ``pause``. Commands run one at a time, and
each answer goes to the line that sent the command.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from sondalog.ala1.commands import MAX_LINE, Interpreter
from sondalog.ala1.hardware import Hardware
from sondalog.ala1.model import Identity
from sondalog.ala1.state import ModuleState, NeedWait, NvStore

log = logging.getLogger(__name__)

CR, LF, BS, DEL, ESC, XON, XOFF = 0x0D, 0x0A, 0x08, 0x7F, 0x1B, 0x11, 0x13
#: §3.4.5: a command must be entered within one minute of its first character.
ENTRY_TIMEOUT = 60.0
BREAK = b"BREAK\r\n"


@dataclass(slots=True)
class Output:
    """Bytes for one line; ``baud`` is the rate to pace them at when the line is paced."""

    line: int
    data: bytes
    baud: int | None = None


@dataclass
class _Line:
    """Line state of one connection (§3.4)."""

    buffer: list[str] = field(default_factory=list)
    echo: bool = False
    started: float | None = None  # time of the first character of the command
    overflow: bool = False
    pending: str | None = None  # a complete command waiting for its pause
    run_at: float = 0.0
    backlog: bytearray = field(default_factory=bytearray)  # received during a pause


class Engine:
    """One ALA1 module: its state and the lines attached to it."""

    def __init__(
        self, identity: Identity, store: NvStore, now: float, hardware: Hardware | None = None
    ) -> None:
        self.identity = identity
        self.state = ModuleState(identity, store, now, hardware)
        self.interpreter = Interpreter(self.state)
        self._lines: dict[int, _Line] = {}
        self._next_id = 1

    # -- lines -----------------------------------------------------------------------------
    def open_line(self) -> int:
        """Attach a new line (a connection); returns its id."""
        line_id = self._next_id
        self._next_id += 1
        self._lines[line_id] = _Line()
        return line_id

    def close_line(self, line_id: int) -> None:
        self._lines.pop(line_id, None)

    # -- input -----------------------------------------------------------------------------
    def receive(self, line_id: int, data: bytes, now: float) -> list[Output]:
        """Bytes received on a line at time ``now``; returns what to send."""
        line = self._lines[line_id]
        out: list[Output] = []
        self.state.run_sampling(now)
        self._expire(line_id, line, now, out)
        if line.pending is not None:
            line.backlog.extend(data)
            return out
        self._feed(line_id, line, data, now, out)
        return out

    def advance(self, now: float) -> list[Output]:
        """Run what is due at ``now``: samples, paused commands, entry timeouts."""
        out: list[Output] = []
        self.state.run_sampling(now)
        for line_id, line in list(self._lines.items()):
            self._expire(line_id, line, now, out)
        return out

    def next_deadline(self) -> float | None:
        """Clock time at which :meth:`advance` must be called next (None: only on input)."""
        sampling = self.state.next_event_host()
        deadlines = [] if sampling is None else [sampling]
        for line in self._lines.values():
            if line.pending is not None:
                deadlines.append(line.run_at)
            elif line.started is not None:
                deadlines.append(line.started + ENTRY_TIMEOUT)
        return min(deadlines, default=None)

    # -- internals ---------------------------------------------------------------------------
    def _expire(self, line_id: int, line: _Line, now: float, out: list[Output]) -> None:
        if line.pending is not None and now >= line.run_at:
            command, line.pending = line.pending, None
            self._run(line_id, command, now, out)
            backlog, line.backlog = bytes(line.backlog), bytearray()
            if backlog:
                self._feed(line_id, line, backlog, now, out)
        if line.started is not None and now - line.started >= ENTRY_TIMEOUT:
            self._break(line_id, line, out)

    def _break(self, line_id: int, line: _Line, out: list[Output]) -> None:
        """§3.4.3, §3.4.5: discard the partial command; ``BREAK`` when echo is on."""
        if line.echo:
            out.append(Output(line_id, b"\r\n" + BREAK))
        self._reset(line)

    @staticmethod
    def _reset(line: _Line) -> None:
        line.buffer.clear()
        line.echo = False
        line.started = None
        line.overflow = False

    def _feed(self, line_id: int, line: _Line, data: bytes, now: float, out: list[Output]) -> None:
        echo = bytearray()
        for index, byte in enumerate(data):
            if byte in (CR, LF):
                if line.echo:
                    echo += b"\r\n"
                if echo:
                    out.append(Output(line_id, bytes(echo)))
                    echo = bytearray()
                text = "".join(line.buffer)
                overflow = line.overflow
                self._reset(line)
                self._complete(line_id, line, text, overflow, now, out)
                if line.pending is not None:
                    line.backlog.extend(data[index + 1 :])
                    return
            elif byte == ESC:
                if echo:
                    out.append(Output(line_id, bytes(echo)))
                    echo = bytearray()
                self._break(line_id, line, out)
            elif byte in (BS, DEL):
                if line.buffer:
                    line.buffer.pop()
                    if line.echo:
                        echo += b"\b \b"
            elif byte in (XON, XOFF):
                continue  # flow control, not command text (§6.11.1)
            else:
                if line.started is None:
                    line.started = now
                    if byte == ord("+"):
                        line.echo = True  # §3.4.2
                        echo += b"+"
                        continue
                if len(line.buffer) < MAX_LINE:
                    line.buffer.append(chr(byte))
                    if line.echo:
                        echo.append(byte)
                else:
                    line.overflow = True
        if echo:
            out.append(Output(line_id, bytes(echo)))

    def _complete(
        self, line_id: int, line: _Line, text: str, overflow: bool, now: float, out: list[Output]
    ) -> None:
        if not text.strip(" "):
            return  # an empty line gets no answer
        pause = None if overflow else self.interpreter.pause_of(text)
        if pause:
            line.pending = text
            line.run_at = now + pause
            return
        self._run(line_id, text, now, out, overflow=overflow)

    def _run(
        self, line_id: int, text: str, now: float, out: list[Output], *, overflow: bool = False
    ) -> None:
        try:
            answer = self.interpreter.run_line(text, now, overflow=overflow)
        except NeedWait as wait:  # §6.5.13: the line runs again once its sensors are ready
            line = self._lines[line_id]
            line.pending = text
            line.run_at = now + wait.seconds
            return
        except Exception:  # DESIGN.md point 6: never stop the device loop
            log.exception("internal error on line %r", text)
            answer = self.interpreter.error_answer(text)
        if answer is not None and answer.data:
            out.append(Output(line_id, answer.data, answer.baud))
