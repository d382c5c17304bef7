"""The client's wait for pipelined answers, woken once when they are in (issue 24; §3.3, §7).

The client's stream wakes its one waiter for every piece of bytes the line delivers (a
logger answers chained lines one at a time: a piece a line on loopback). A reader that knows
how many lines the answers hold (:mod:`sondalog.client.station_read`: every command answers
one line, then ``OK``) need not be woken for each: :class:`CountedWait` stands in the
stream's waiter slot, counts the line ends of each piece as it arrives (in C, over the new
bytes only), sends the next lines of a window itself when the answers before them are in
(no wake for that either), and resolves only when

- the buffer holds ``lines`` line ends (the answers are in; bytes after them are the
  caller's to judge),
- a ``stop`` line arrived (``ERROR``: a refused line answers with fewer lines, §3.3.1; the
  caller checks whether that completes the answers and, if not, waits again with an empty
  ``stop``: every further piece wakes it until they are whole),
- the buffer holds more than ``most`` bytes (everything an outsider can fill is bounded), or
- the line is closed (woken with no new bytes): True in each case;
- ``timeout`` seconds pass after the last byte received (the timeout runs from the last
  byte, so an answer still arriving on a slow line is never cut): False.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterable
from typing import Protocol

from sondalog.client.ala1_codec import ConnectionLost, IncompleteAnswer, NoAnswer

#: The line a refused command answers with (§3.3.1).
ERROR = b"ERROR\r\n"


#: A piece of lines sent once the answers before it are in: the line ends those answers
#: hold, how many request lines they answer, the bytes.
Piece = tuple[int, int, bytes]


class Stream(Protocol):
    """What :func:`read_answers` needs of the client's stream (``client.ala1._Stream``)."""

    buffer: bytearray
    closed: bool
    transport: asyncio.Transport | None

    async def wait_on(self, waiter: asyncio.Future[bool]) -> bool: ...


class Line(Protocol):
    """What a :class:`CountedWait` does with the line: asyncio's transport interface."""

    def write(self, data: bytes) -> None: ...

    def pause_reading(self) -> None: ...

    def resume_reading(self) -> None: ...


class CountedWait(asyncio.Future[bool]):
    """The stream's waiter (:meth:`~sondalog.client.ala1._Stream.wait_on`): the stream
    calls :meth:`set_result` for every piece of bytes (and for the close). ``pieces``
    (last first; shared with the caller, who sees what is left) are written to ``line`` as
    soon as the buffer holds their count of line ends.

    ``gather`` (seconds): after a piece that does not end the wait, the line is not read
    for that long, so what the peer sends meanwhile is taken in one read (a logger writes
    an answer a line: some 50 pieces a configuration read on loopback, each a wake of the
    event loop, a ``recv`` and a callback). It delays the end by at most ``gather``."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        buffer: bytearray,
        *,
        lines: int,
        most: int,
        stop: bytes,
        timeout: float,
        seen: int = 0,
        pieces: list[Piece] | None = None,
        line: Line | None = None,
        gather: float = 0.0,
    ) -> None:
        super().__init__(loop=loop)
        self._pieces = pieces if pieces and line is not None else None
        self._line = line
        self._gather = gather if line is not None else 0.0
        self._paused: asyncio.TimerHandle | None = None  # reading resumes then
        self._clock = loop.time
        self._buffer = buffer
        self._lines = lines
        self._most = most
        self._stop = stop
        self._timeout = timeout
        self._seen = min(seen, len(buffer))  # bytes already looked at (a wait after a stop)
        self._count = buffer.count(b"\n", 0, self._seen)
        self._last = loop.time()
        self._timer: asyncio.TimerHandle | None = loop.call_at(self._last + timeout, self._due)

    def set_result(self, result: bool) -> None:
        """Bytes arrived (or the line closed: no new bytes): resolve only at an end."""
        if self.done():
            return
        if result and len(self._buffer) > self._seen and not self.enough():
            if self._gather and self._paused is None:
                assert self._line is not None
                self._line.pause_reading()
                self._paused = self.get_loop().call_later(self._gather, self._resume)
            return
        self._end(result)

    def enough(self) -> bool:
        """Take the bytes that arrived since the last look: True when they make an end."""
        buffer, seen = self._buffer, self._seen
        size = len(buffer)
        if size <= seen:
            return False
        self._count += buffer.count(b"\n", seen)
        self._seen = size
        self._last = self._clock()
        pieces = self._pieces
        while pieces and self._count >= pieces[-1][0]:
            assert self._line is not None
            self._line.write(pieces.pop()[2])
        return (
            self._count >= self._lines
            or size > self._most
            or not self._stop  # every piece wakes
            or buffer.find(self._stop, max(seen - len(self._stop) + 1, 0)) >= 0
        )

    def cancel(self, msg: object = None) -> bool:
        self._drop_timer()
        return super().cancel(msg)

    def _due(self) -> None:
        """The timer: silent for ``timeout`` since the last byte, or set again from it."""
        self._timer = None
        if self.done():
            return
        due = self._last + self._timeout
        if self._clock() < due:
            self._timer = self.get_loop().call_at(due, self._due)
            return
        self._end(False)

    def _end(self, result: bool) -> None:
        self._drop_timer()
        super().set_result(result)

    def _resume(self) -> None:
        if self._paused is not None:
            self._paused.cancel()
            self._paused = None
            assert self._line is not None
            self._line.resume_reading()

    def _drop_timer(self) -> None:
        """The end: no timer left, and the line read again (always)."""
        self._resume()
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None


async def read_answers(
    stream: Stream,
    payload: bytes,
    lines: int,
    most: int,
    answered: Callable[[bytes, int], tuple[int, bool]],
    more: Iterable[Piece],
    timeout: float,
    gather: float = 0.0,
) -> bytes:
    """:meth:`~sondalog.client.ala1.Ala1Client.read_counted` (its lock held): write
    ``payload``, then each of ``more``'s pieces once the answers hold its count of line
    ends (a window: the lines sent ahead stay bounded while the answers flow without a round
    trip's pause); the bytes received once they hold ``lines`` line ends.

    A refused line answers with fewer lines (its echo and ``ERROR``, §3.3.1), so once an
    ``ERROR`` line came the line ends no longer say which lines are answered: from then on
    ``answered(bytes, pieces sent)`` does (how many request lines have whole answers,
    refusals included, and whether the bytes are whole answers to every line sent and
    nothing more), at each piece of the answers. ``gather``: :class:`CountedWait`'s.

    Raises :class:`NoAnswer` when nothing arrives within ``timeout``,
    :class:`IncompleteAnswer` when the answers stop short for that long after their last
    byte or grow past ``most`` bytes (a peer that talks on), :class:`ConnectionLost` when
    the line closes."""
    buffer, transport = stream.buffer, stream.transport
    assert transport is not None
    buffer.clear()
    transport.write(payload)
    pending = list(more)
    pending.reverse()
    total = len(pending) + 1
    loop = asyncio.get_running_loop()
    seen, refused = 0, False
    while True:
        wait = CountedWait(
            loop, buffer, lines=lines, most=most, stop=b"" if refused else ERROR,
            timeout=timeout, seen=seen, pieces=None if refused else pending, line=transport,
            gather=gather,
        )  # fmt: skip
        if wait.enough():  # what is in already makes an end
            wait.cancel()
            woke = True
        else:
            woke = await stream.wait_on(wait)
        size = len(buffer)
        if size > most:
            got = bytes(buffer)
            buffer.clear()
            raise IncompleteAnswer(f"more than the answers can be: ...{got[-60:]!r}", got)
        if buffer.count(b"\n") >= lines:
            got = bytes(buffer)
            buffer.clear()
            return got
        refused = refused or buffer.find(ERROR, max(seen - len(ERROR) + 1, 0)) >= 0
        if refused and woke and not stream.closed:
            # the line ends no longer say which lines are answered: the answers do
            done, whole = answered(bytes(buffer), total - len(pending))
            if whole:
                got = bytes(buffer)
                buffer.clear()
                return got
            while pending and done >= pending[-1][1]:
                transport.write(pending.pop()[2])
        if woke and not stream.closed:
            seen = size
            continue
        got = bytes(buffer)
        buffer.clear()
        line = payload.split(b"\r", 1)[0].decode("latin-1")
        if stream.closed:
            raise ConnectionLost.during(line, got)
        if not got:
            raise NoAnswer(f"no answer to {line!r}")
        raise IncompleteAnswer(f"the answers stopped short: ...{got[-60:]!r}", got)
