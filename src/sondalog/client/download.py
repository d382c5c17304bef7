"""Incremental download of a logger's record with resume, verification and gap detection.

The download resumes by the last row the caller already holds (its record point
``YYYYMMDDhhmmss.c``), never by the logger's last-read points (§6.6.2), which data messages and
other users move. Each chunk is one command line (§7.1, §8.4.1)::

    crcsum read record 1 from start read record N from date/20070301120000.3/

The first command returns the oldest row the logger still holds; the second the rows strictly
after the cursor (§6.6.1.1). When the oldest row comes after the cursor, a cyclic record has
overwritten rows before they were fetched: the chunk carries a :class:`Gap` saying which time
span was lost and about how many rows (estimated from the row rate around it, since a wrapped
record reports no count, §6.6.5). Every chunk is verified with ``crcsum`` and read again on a
mismatch or a broken answer.

The chunk size adapts to the line: it aims at ``target_seconds`` of transfer per chunk, so a
slow serial line or GSM call gets small chunks (a re-read costs little) and TCP large ones (the
turnaround between chunks costs little).

At every contact :meth:`Download.identify` reads ``i snumber``, ``date`` (§6.2) and the channel
names (§6.5.3) and notes the logger's clock offset against the host's clock.
:meth:`Download.contact` does the same together with the caller's other commands and the first
chunk in one pipelined write (the module answers the lines in order, §7): one round trip a
contact when the channel count is the one of the last contact, which a slow serial line or a
GSM call pays in seconds. A pipelined answer that fails its checks falls back to the step by
step path, so both store the same rows. The collector's contact chains all of it into fewer
lines still (:func:`sondalog.client.visit.visit`, which falls back to :meth:`Download.contact`).
"""

from __future__ import annotations

import functools
import time
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from zoneinfo import ZoneInfo

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import (
    MAX_LINE,
    ChecksumError,
    IncompleteAnswer,
    NoAnswer,
    Request,
    Response,
    Status,
)
from sondalog.client.records import (
    Channel,
    Row,
    RowError,
    parse_key,
    parse_row,
    split_name,
    stamp,
)

#: Tries of one chunk before giving up (a mismatch, a broken or missing answer).
ATTEMPTS = 4
FIRST_ROWS = 20
MIN_ROWS = 20
MAX_ROWS = 5000


class DownloadError(Exception):
    """The logger's answers cannot be used (garbage, refused commands, repeated mismatches)."""


@dataclass(frozen=True, slots=True)
class ClockReading:
    """The logger's clock (§6.2) read at a contact, against the host's clock."""

    logger_time: datetime
    """Naive: what ``read date`` answered."""
    host_time: float
    """The host's clock (POSIX seconds) in the middle of the exchange."""
    offset: float
    """Seconds the logger is ahead of the host (negative: behind), in the logger's time zone
    when it is known, else in the host's."""

    def describe(self) -> str:
        ahead = "ahead of" if self.offset >= 0 else "behind"
        return (
            f"logger clock {self.logger_time.isoformat()}, "
            f"{abs(self.offset):.0f} s {ahead} this computer"
        )


@dataclass(frozen=True, slots=True)
class LoggerInfo:
    """What :meth:`Download.identify` learns at a contact."""

    snumber: str
    channels: dict[int, Channel]
    clock: ClockReading


@dataclass(frozen=True, slots=True)
class Gap:
    """Rows lost before they were fetched: overwritten by a cyclic record, or cleared."""

    after: str
    """The last row held (record point)."""
    before: str
    """The oldest row the logger still has."""
    rows: int | None
    """About how many rows were lost (None when the rate cannot be estimated)."""

    def describe(self) -> str:
        start, _ = parse_key(self.after)
        end, _ = parse_key(self.before)
        count = "an unknown number of rows" if self.rows is None else f"about {self.rows} rows"
        return (
            f"gap: rows were lost before they were fetched (a cyclic record overwrote them, or "
            f"the record was cleared): {count} lost between "
            f"{start.isoformat()} ({self.after}, the last row held) and {end.isoformat()} "
            f"({self.before}, the oldest row left)"
        )


@dataclass(frozen=True, slots=True)
class Chunk:
    """One verified chunk of rows, oldest first."""

    rows: list[Row]
    gap: Gap | None = None
    bytes: int = 0
    rereads: int = 0

    @property
    def cursor(self) -> str | None:
        return self.rows[-1].key if self.rows else None


@dataclass
class Download:
    """Download the rows after ``after`` (None: the whole record) over ``client``."""

    client: Ala1Client
    after: str | None = None
    zone: ZoneInfo | None = None
    target_seconds: float = 6.0
    max_rows: int = MAX_ROWS
    clock: Callable[[], float] = time.time
    rows_per_chunk: int = FIRST_ROWS
    include_after: bool = False
    """The first chunk also returns the row ``after`` itself (read from its second, ``from
    date/YYYYMMDDhhmmss/``), for a caller that may hold only part of it (a torn file)."""
    info: LoggerInfo | None = None
    record_empty: bool = False
    """The logger held no rows at all at the last chunk (cleared, or never written)."""
    _rate: float = field(default=0.0, repr=False)
    _row_bytes: float = field(default=100.0, repr=False)
    #: The first chunk read by :meth:`contact`: (its command, answer, seconds of transfer).
    _prefetched: tuple[str, Response, float] | None = field(default=None, repr=False)

    async def identify(self) -> LoggerInfo:
        """Read the serial number, the clock and the channel names (one round trip each)."""
        before = self.clock()
        head = await self._ask(list(_HEAD))
        after = self.clock()
        count = _count(head)
        names = await self._ask(_names(count))
        return self._identified(head, names, before, after)

    async def contact(
        self, extra: Sequence[str] = (), channels: int | None = None
    ) -> tuple[LoggerInfo, list[Response]]:
        """:meth:`identify`, the ``extra`` commands (their answers are returned, an error
        response included) and the first chunk of :meth:`chunks`, in one pipelined write when
        ``channels`` (the channel count of the last contact) is still right, else two.

        A pipelined answer that is broken or fails its ``crcsum`` is not trusted: the contact
        goes on step by step (:meth:`identify`, then ``extra``, then the chunks with their
        re-reads), as if nothing had been pipelined. No answer to the first command is the
        logger's silence and is raised as it is."""
        guess = channels if channels is not None and 1 <= channels <= 99 else 0
        first = self._command(self.rows_per_chunk)
        lines = _chained(guess)
        requests: list[Request | str] = [*lines, *extra, Request(first, crcsum=True)]
        before = self.clock()
        try:
            answers = await self.client.pipeline(requests)
            head = _unchain(lines[:1], answers[:1], _HEAD)
            count = _count(head)
            names = None
            if count == guess:
                names = _unchain(lines[1:], answers[1 : len(lines)], _names(guess))
        except (ChecksumError, IncompleteAnswer, NoAnswer) as exc:
            if isinstance(exc, NoAnswer) and repr(lines[0]) in str(exc):
                raise
            info = await self.identify()
            return info, await self.client.pipeline(extra) if extra else []
        after = self.clock()
        if names is None:
            names = await self._ask(_names(count))
        rest = answers[len(lines) :]
        chunk = rest[-1]
        if chunk.error:
            raise DownloadError(f"the logger refused {first!r}")
        total = sum(len(a.raw) for a in answers) or 1
        self._prefetched = (first, chunk, max(after - before, 1e-6) * len(chunk.raw) / total)
        return self._identified(head, names, before, after), list(rest[:-1])

    def prefetched(
        self, rows: Sequence[str], raw: bytes, crc: tuple[int, int], elapsed: float
    ) -> None:
        """The first chunk, read with other commands (:mod:`sondalog.client.visit`): the
        lines and bytes (rows, ``crcsum`` line, ``OK``) the answer of :meth:`first` had."""
        response = Response(f"crcsum {self.first}", tuple(rows), Status.OK, raw, crc=crc)
        self._prefetched = (self.first, response, elapsed)

    @property
    def first(self) -> str:
        """The command line of the next chunk (``crcsum`` not included)."""
        return self._command(self.rows_per_chunk)

    def identified(
        self,
        snumber: str,
        channels: dict[int, Channel],
        logger_time: datetime,
        span: tuple[float, float],
    ) -> LoggerInfo:
        """:attr:`info` from what the caller read between the host times ``span``."""
        self.info = LoggerInfo(snumber, channels, self._clock(logger_time, *span))
        return self.info

    async def names(self, first: int, last: int) -> list[str]:
        """The names of channels ``first``..``last`` (§6.5.3), one command each, pipelined."""
        answers = await self._ask([_name(n) for n in range(first, last + 1)])
        try:
            return [_single(answer) for answer in answers]
        except ValueError as exc:
            raise DownloadError(f"the logger answers garbage: {exc}") from None

    def _clock(self, logger_time: datetime, before: float, after: float) -> ClockReading:
        middle = (before + after) / 2
        host = datetime.fromtimestamp(middle, self.zone).replace(tzinfo=None)
        return ClockReading(logger_time, middle, (logger_time - host).total_seconds())

    def _identified(
        self, head: list[Response], names: list[Response], before: float, after: float
    ) -> LoggerInfo:
        try:
            snumber = _single(head[0])
            logger_time = stamp(_single(head[1]))
            channels = {n: split_name(_single(r)) for n, r in enumerate(names, start=1)}
        except ValueError as exc:
            raise DownloadError(f"the logger answers garbage: {exc}") from None
        self.info = LoggerInfo(snumber, channels, self._clock(logger_time, before, after))
        return self.info

    async def chunks(self) -> AsyncIterator[Chunk]:
        """Verified chunks until the logger has no more rows; ``after`` follows each chunk."""
        while True:
            wanted = self.rows_per_chunk
            prefetched, self._prefetched = self._prefetched, None
            if prefetched is not None and prefetched[0] == self._command(wanted):
                _, response, elapsed = prefetched  # read by contact() with the identification
                chunk, sent = self._parse(response, wanted, 0)
                self._adapt(chunk, elapsed)
            else:
                chunk, sent = await self._chunk(wanted)
            self.include_after = False
            if chunk.rows:
                self.after = chunk.cursor
            if chunk.rows or chunk.gap:
                yield chunk
            if sent < wanted:
                return

    async def _chunk(self, wanted: int) -> tuple[Chunk, int]:
        """One verified chunk and the number of rows the logger sent for it."""
        command = self._command(wanted)
        expected = wanted * self._row_bytes / self._rate if self._rate > 0 else 0.0
        timeout = max(self.client.timeout, 5.0 + 3 * expected)
        rereads = 0
        for attempt in range(ATTEMPTS):
            started = self.clock()
            try:
                response = await self.client.command(command, crcsum=True, timeout=timeout)
            except (ChecksumError, IncompleteAnswer, NoAnswer) as exc:
                if attempt == ATTEMPTS - 1:
                    raise DownloadError(f"{command!r} failed {ATTEMPTS} times: {exc}") from exc
                rereads += 1
                timeout *= 2
                continue
            if response.error:
                raise DownloadError(f"the logger refused {command!r}")
            elapsed = max(self.clock() - started, 1e-6)
            chunk, sent = self._parse(response, wanted, rereads)
            self._adapt(chunk, elapsed)
            return chunk, sent
        raise AssertionError("unreachable")

    def _command(self, wanted: int) -> str:
        """The command line of the next chunk of ``wanted`` rows (``crcsum`` added by the
        request)."""
        if self.after is None:
            return f"read record {wanted} from start"
        point = self.after[:14] if self.include_after else self.after
        return f"read record 1 from start read record {wanted} from date/{point}/"

    def _parse(self, response: Response, wanted: int, rereads: int) -> tuple[Chunk, int]:
        lines = list(response.lines)
        try:
            rows = [parse_row(line) for line in lines]
        except RowError as exc:
            raise DownloadError(f"the logger answers garbage: {exc}") from None
        size = len(response.raw)
        self.record_empty = not rows
        if self.after is None or not rows:
            return Chunk(rows, None, size, rereads), len(rows)
        oldest, rows = rows[0], rows[1:]
        sent = len(rows)
        if sent > wanted:
            raise DownloadError(f"the logger answered {sent} rows for {wanted}")
        if self.include_after:  # the rows of the cursor's second before the cursor are held
            rows = [row for row in rows if row.key >= self.after]
        gap = None
        if oldest.key > self.after:
            gap = Gap(self.after, oldest.key, _estimate(self.after, oldest, rows))
        return Chunk(rows, gap, size, rereads), sent

    def _adapt(self, chunk: Chunk, elapsed: float) -> None:
        """Size the next chunk for ``target_seconds`` at the rate seen (growing 4x at most)."""
        if not chunk.rows:
            return
        self._rate = chunk.bytes / elapsed
        self._row_bytes = chunk.bytes / (len(chunk.rows) + 1)
        rows = int(self.target_seconds * self._rate / self._row_bytes)
        rows = min(rows, 4 * self.rows_per_chunk, self.max_rows)
        self.rows_per_chunk = max(MIN_ROWS, rows)

    async def _ask(self, commands: list[str]) -> list[Response]:
        try:
            answers = await self.client.pipeline(commands)
        except (IncompleteAnswer, ChecksumError) as exc:
            raise DownloadError(f"the logger answers garbage: {exc}") from None
        for command, answer in zip(commands, answers, strict=True):
            _refused(command, answer)
        return answers


#: The identification's first commands (§6.2, §6.4, §6.5.1).
_HEAD = ("read i snumber", "read date", "read channel max number")


def _names(count: int) -> list[str]:
    """The commands reading the names of channels 1..``count`` (§6.5.3)."""
    return list(_NAMES[:count]) if count <= len(_NAMES) else [_name(n) for n in range(1, count + 1)]


def _name(n: int) -> str:
    return f"read channel {n} name"


_NAMES = tuple(_name(n) for n in range(1, 100))


@functools.cache
def _chained(guess: int) -> tuple[str, ...]:
    """The identification as chained lines (§7: a chained line answers every command's data
    line, then one ``OK``): :data:`_HEAD` in the first, the names of ``guess`` channels in
    lines of at most :data:`MAX_LINE` characters after it (a wrong guess refuses only those)."""
    lines: list[list[str]] = [list(_HEAD), []]
    for command in _names(guess):
        if lines[-1] and len(" ".join([*lines[-1], command])) > MAX_LINE:
            lines.append([])
        lines[-1].append(command)
    return tuple(" ".join(line) for line in lines if line)


def _unchain(
    lines: Sequence[str], answers: Sequence[Response], commands: Sequence[str]
) -> list[Response]:
    """The answers of chained ``lines`` of ``commands``, one per command (each answers one
    data line); a refused line is :class:`DownloadError`, another count of data lines
    :class:`IncompleteAnswer` (the step by step path then reads)."""
    out: list[Response] = []
    for line, answer in zip(lines, answers, strict=True):
        _refused(line, answer)
        mine = commands[len(out) : len(out) + line.count("read ")]
        if len(answer.lines) != len(mine):
            raise IncompleteAnswer(f"{line!r} answered {len(answer.lines)} lines", answer.raw)
        out.extend(
            Response(c, (text,), answer.status, b"")
            for c, text in zip(mine, answer.lines, strict=True)
        )
    if len(out) != len(commands):
        raise IncompleteAnswer(f"{len(out)} answers for {len(commands)} commands", b"")
    return out


def _refused(command: str, answer: Response) -> None:
    if answer.error:
        raise DownloadError(f"the logger refused {command!r}: is it an ALA1?")


def _count(head: list[Response]) -> int:
    """The channel count of ``read channel max number``; :class:`DownloadError` for garbage."""
    try:
        _single(head[0])
        stamp(_single(head[1]))
        count = int(_single(head[2]))
    except ValueError as exc:
        raise DownloadError(f"the logger answers garbage: {exc}") from None
    if not 1 <= count <= 99:
        raise DownloadError(f"the logger answers garbage: {count} channels")
    return count


def _single(response: Response) -> str:
    if len(response.lines) != 1:
        raise ValueError(f"expected one line, got {list(response.lines)[:3]!r}")
    return response.lines[0]


def _estimate(after: str, oldest: Row, rows: list[Row]) -> int | None:
    """About how many rows fit between ``after`` and ``oldest`` at the rate of ``rows``."""
    start, _ = parse_key(after)
    seen = rows or [oldest]  # after a gap the rows start at the oldest row
    span = (seen[-1].time - seen[0].time).total_seconds()
    if len(seen) < 2 or span <= 0:
        return None
    rate = (len(seen) - 1) / span
    lost = round((oldest.time - start).total_seconds() * rate) - 1
    return max(lost, 1)


__all__ = [
    "Chunk",
    "ClockReading",
    "Download",
    "DownloadError",
    "Gap",
    "LoggerInfo",
]
