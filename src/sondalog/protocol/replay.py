"""Replay of a recorded line (issue 23): a device core that answers the recorded commands with
the recorded answers. Pure: bytes in, bytes out; the runtime is :mod:`sondalog.app.replay`.

A trace (:mod:`sondalog.protocol.line_trace`) is cut into **exchanges**: what the host sent
and what the device answered to it. A command line ends at CR or LF (ALA1 notes §1: CRLF and
LFCR are one end, an empty line gets no answer); host bytes the device answered without a
line end (an XMODEM ``C``, ``ACK``, a block) are one raw exchange. Answers to lines sent
together (a pipeline) are split at their final lines (``OK``, a decorated ``...,OK``,
``ERROR``, §3.3); bytes after the last final line belong to the last line sent.

- **strict**: the host must send the recorded exchanges in order. An exchange that differs
  is a :class:`Deviation`: the host gets the protocol's error response (what it sent, then
  ``ERROR``, §3.3.1: the one error answer a host can tell), the deviation says what was
  expected (the runtime prints it as it happens), and the replay waits for the expected
  exchange again. A command past the end of the recording, and exchanges never sent when
  the line closes, are deviations too.
- **lenient**: a command is answered by its text (spaces normalised), in any order; a text
  recorded several times gets its answers in the recorded order, the last one repeating; an
  unknown command gets the protocol's error response (the line, then ``ERROR``, §3.3.1) and
  is noted as a deviation (``unknown``).

Each line (connection) replays the recording from its start.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

from sondalog.protocol.device import Effect, Event, LineSend
from sondalog.protocol.line_trace import Chunk

#: Host bytes held on one line without a line end before they count as a deviation.
MAX_PENDING = 4096
#: Deviations kept per device (the count goes on).
MAX_DEVIATIONS = 1000
_ENDS = b"\r\n"


@dataclass
class Exchange:
    """One command line (``raw`` False: ``sent`` without its line end) or raw bytes, and the
    answer recorded for it."""

    sent: bytes
    raw: bool = False
    answer: bytearray = field(default_factory=bytearray)


@dataclass(frozen=True)
class Deviation:
    """The host did not do what the recording says (or, lenient, sent an unknown command)."""

    line: int
    index: int
    """The exchange expected (0-based; the count of exchanges for "past the end")."""
    expected: str | None
    got: str | None
    kind: str = "different"
    """``different``, ``beyond`` (past the end), ``missing`` (never sent), ``unknown``."""
    unsent: int = 0
    """``missing``: how many exchanges, from ``index`` on, were never sent."""

    def describe(self) -> str:
        number = self.index + 1
        if self.kind == "beyond":
            return f"line {self.line}: {self.got!r} after the last recorded exchange ({number - 1})"
        if self.kind == "missing":
            more = f" and the {self.unsent - 1} after it" if self.unsent > 1 else ""
            return f"line {self.line}: exchange {number} {self.expected!r}{more} never sent"
        if self.kind == "unknown":
            return f"line {self.line}: {self.got!r} is not in the recording"
        return f"line {self.line}: exchange {number}: expected {self.expected!r}, got {self.got!r}"


def _final(line: bytes) -> bool:
    """Does an answer line end an answer (``OK``, ``...,OK``, ``ERROR``; §3.3)?"""
    end = line.rstrip(_ENDS)
    return end.endswith(b"OK") or end == b"ERROR"


def _shown(data: bytes) -> str:
    """Host bytes as a deviation names them: at most 120 characters."""
    text = data[:120].decode("latin-1")
    return text + "..." if len(data) > 120 else text


def _error(got: bytes) -> bytes:
    """§3.3.1: the line as received (at most 120 characters), then ERROR."""
    return got[:120] + b"\r\nERROR\r\n"


def _answer_lines(data: bytes) -> list[bytes]:
    """``data`` cut after each LF (the last piece may have none)."""
    pieces = data.split(b"\n")
    out = [p + b"\n" for p in pieces[:-1]]
    if pieces[-1]:
        out.append(pieces[-1])
    return out


def exchanges(chunks: Iterable[Chunk]) -> tuple[bytes, list[Exchange]]:
    """The device's bytes before any host bytes, and the exchanges of a trace.

    The host's bytes between two answers (a burst) are command lines when they are text
    ending at a line end (a pipeline when there are several); otherwise (an XMODEM block, a
    command and the ``C`` that starts its transfer, line editing) one raw exchange."""
    prologue = bytearray()
    found: list[Exchange] = []
    waiting: list[Exchange] = []  # the exchanges of the last burst still taking answer lines
    burst = bytearray()
    for chunk in chunks:
        if chunk.to_device:
            burst += chunk.data
            continue
        if burst:
            waiting = _burst(bytes(burst))
            found += waiting
            burst.clear()
        for piece in _answer_lines(chunk.data):
            if waiting:
                waiting[0].answer += piece
                if len(waiting) > 1 and _final(piece):
                    waiting.pop(0)
            elif found:
                found[-1].answer += piece
            else:
                prologue += piece
    if burst:
        found += _burst(bytes(burst))
    return bytes(prologue), found


def _burst(data: bytes) -> list[Exchange]:
    """The exchanges of what the host sent between two answers."""
    if data[-1:] in (b"\r", b"\n") and all((b >= 0x20 and b != 0x7F) or b in _ENDS for b in data):
        lines = data.replace(b"\n", b"\r").split(b"\r")
        return [Exchange(line) for line in lines if line]
    return [Exchange(data, raw=True)]


def _line_end(data: bytearray) -> int:
    ends = [i for i in (data.find(b"\r"), data.find(b"\n")) if i >= 0]
    return min(ends) if ends else -1


def normalise(text: bytes) -> bytes:
    """Command text as lenient replay compares it: runs of spaces as one, none at the ends."""
    return b" ".join(part for part in text.split(b" ") if part)


class _Line:
    """One connection's place in the recording."""

    def __init__(self, prologue: bytes) -> None:
        self.pending = bytearray()
        self.next = 0  # strict: the exchange expected next
        self.used: dict[bytes, int] = {}  # lenient: answers given per text
        self.greeting = prologue


class ReplayDevice:
    """A :class:`~sondalog.protocol.device.Device` that replays a trace's exchanges."""

    def __init__(self, chunks: Sequence[Chunk], *, lenient: bool = False) -> None:
        self.prologue, self.exchanges = exchanges(chunks)
        self.lenient = lenient
        self.deviations: list[Deviation] = []
        self.deviation_count = 0
        self.played = 0
        """Exchanges answered from the recording, over all lines."""
        self.on_deviation: Callable[[Deviation], None] | None = None
        """Told of each deviation as it happens (the runtime prints them)."""
        self.on_close: Callable[[int], None] | None = None
        """Told when a line closes (after its missing exchanges are noted)."""
        self._lines: dict[int, _Line] = {}
        self._next_id = 0
        self._by_text: dict[bytes, list[Exchange]] = {}
        self._raw: dict[bytes, list[Exchange]] = {}
        for exchange in self.exchanges:
            if exchange.raw:
                self._raw.setdefault(exchange.sent, []).append(exchange)
            else:
                self._by_text.setdefault(normalise(exchange.sent), []).append(exchange)

    # -- the Device contract ------------------------------------------------------------------
    def open_line(self, *, paced: bool = False) -> int:
        self._next_id += 1
        self._lines[self._next_id] = _Line(self.prologue)
        return self._next_id

    def close_line(self, line: int) -> None:
        state = self._lines.pop(line, None)
        if state is not None and not self.lenient and state.next < len(self.exchanges):
            expected = _shown(self.exchanges[state.next].sent)
            unsent = len(self.exchanges) - state.next
            self._deviate(Deviation(line, state.next, expected, None, "missing", unsent))
        if state is not None and self.on_close is not None:
            self.on_close(line)

    def line_speed(self) -> int:
        return 9600  # §6.11.2: the factory com speed (answers are not paced)

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        return []

    def advance(self, now: float) -> Sequence[Effect]:
        return []

    def next_deadline(self) -> float | None:
        return None

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        state = self._lines.get(line)
        if state is None:
            return []
        state.pending += data
        out = bytearray(state.greeting)
        state.greeting = b""
        step = self._lenient_step if self.lenient else self._strict_step
        while (answer := step(line, state)) is not None:
            out += answer
        if len(state.pending) > MAX_PENDING:  # no line end in sight: answer what came
            got = bytes(state.pending[:60])
            state.pending.clear()
            out += self._unknown(line, got) if self.lenient else self._strict(line, state, got)
        return [LineSend(line, bytes(out))] if out else []

    # -- matching -----------------------------------------------------------------------------
    def _strict_step(self, line: int, state: _Line) -> bytes | None:
        """The answer to the next whole exchange in ``state.pending``; None: wait for more."""
        pending = state.pending
        if state.next < len(self.exchanges) and (expected := self.exchanges[state.next]).raw:
            if pending.startswith(expected.sent):
                del pending[: len(expected.sent)]
                return self._play(state, expected)
            if not pending or expected.sent.startswith(pending):
                return None
            got = bytes(pending)
            pending.clear()
            return self._strict(line, state, got)
        text = self._take_line(pending)
        if text is None:
            return None
        return self._strict(line, state, text) if text else b""

    def _strict(self, line: int, state: _Line, got: bytes) -> bytes:
        """Strict: the answer to ``got``, recorded or the deviation's."""
        if state.next >= len(self.exchanges):
            deviation = Deviation(line, state.next, None, _shown(got), "beyond")
        else:
            expected = self.exchanges[state.next]
            if not expected.raw and got == expected.sent:
                return self._play(state, expected)
            deviation = Deviation(line, state.next, _shown(expected.sent), _shown(got))
        self._deviate(deviation)
        return _error(got)

    def _play(self, state: _Line, exchange: Exchange) -> bytes:
        state.next += 1
        self.played += 1
        return bytes(exchange.answer)

    def _lenient_step(self, line: int, state: _Line) -> bytes | None:
        pending = state.pending
        raw = self._raw.get(bytes(pending))
        if raw is not None:
            pending.clear()
            return self._answer_by_text(state, b"\x00raw:" + raw[0].sent, raw)
        if pending and any(sent.startswith(pending) for sent in self._raw):
            return None  # (bounded by MAX_PENDING)
        text = self._take_line(pending)
        if text is None:
            return None
        if not text:
            return b""
        key = normalise(text)
        recorded = self._by_text.get(key)
        if recorded is None:
            return self._unknown(line, text)
        return self._answer_by_text(state, key, recorded)

    def _unknown(self, line: int, got: bytes) -> bytes:
        """Lenient: a command not in the recording gets the protocol's error (§3.3.1)."""
        self._deviate(Deviation(line, -1, None, _shown(got), "unknown"))
        return _error(got)

    def _answer_by_text(self, state: _Line, key: bytes, recorded: list[Exchange]) -> bytes:
        used = state.used.get(key, 0)
        state.used[key] = used + 1
        self.played += 1
        return bytes(recorded[min(used, len(recorded) - 1)].answer)

    @staticmethod
    def _take_line(pending: bytearray) -> bytes | None:
        end = _line_end(pending)
        if end < 0:
            return None
        text = bytes(pending[:end])
        del pending[: end + 1]
        return text

    def _deviate(self, deviation: Deviation) -> None:
        self.deviation_count += 1
        if len(self.deviations) < MAX_DEVIATIONS:
            self.deviations.append(deviation)
        if self.on_deviation is not None:
            self.on_deviation(deviation)
