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
"""

from __future__ import annotations

import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from datetime import datetime
from zoneinfo import ZoneInfo

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import (
    ChecksumError,
    IncompleteAnswer,
    NoAnswer,
    Response,
)
from sondalog.client.records import Channel, Row, RowError, parse_key, parse_row, split_name

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

    async def identify(self) -> LoggerInfo:
        """Read the serial number, the clock and the channel names (one round trip each)."""
        before = self.clock()
        head = await self._ask(["read i snumber", "read date", "read channel max number"])
        after = self.clock()
        try:
            snumber = _single(head[0])
            logger_time = datetime.strptime(_single(head[1]), "%Y%m%d%H%M%S")
            count = int(_single(head[2]))
        except ValueError as exc:
            raise DownloadError(f"the logger answers garbage: {exc}") from None
        if not 1 <= count <= 99:
            raise DownloadError(f"the logger answers garbage: {count} channels")
        names = await self._ask([f"read channel {n} name" for n in range(1, count + 1)])
        channels = {n: split_name(_single(r)) for n, r in enumerate(names, start=1)}
        middle = (before + after) / 2
        host = datetime.fromtimestamp(middle, self.zone).replace(tzinfo=None)
        clock = ClockReading(logger_time, middle, (logger_time - host).total_seconds())
        self.info = LoggerInfo(snumber, channels, clock)
        return self.info

    async def chunks(self) -> AsyncIterator[Chunk]:
        """Verified chunks until the logger has no more rows; ``after`` follows each chunk."""
        while True:
            wanted = self.rows_per_chunk
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
        if self.after is None:
            command = f"read record {wanted} from start"
        else:
            point = self.after[:14] if self.include_after else self.after
            command = f"read record 1 from start read record {wanted} from date/{point}/"
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
            if answer.error:
                raise DownloadError(f"the logger refused {command!r}: is it an ALA1?")
        return answers


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
