"""The record memory (§6.6, §9, spec notes §6).

Rows ``YYYYMMDDhhmmss.c,t,f1,...,fn`` in memory order, oldest first; a row occupies its length
plus CR LF. A cyclic record drops its oldest rows to make room (and from then on reports the
§6.6.5 quirk ``0,1.00,FULL`` until cleared); a linear record refuses rows that do not fit.

The rows live in RAM for fast reads and in the non-volatile store for durability. Every change
is staged: :meth:`RecordMemory.mark` and :meth:`RecordMemory.rollback` make a command line
atomic, and :meth:`RecordMemory.take_changes` hands the store what to write.

In RAM the rows are kept compactly (issue 24: a month of 1-minute rows of 10,000 loggers was
tens of GB as one string object a row): all but the newest rows are sealed into pages of
:data:`PAGE` rows, each one zlib-compressed text with the rows' ends, decompressed when
read (the last few decoded pages are kept, :func:`~sondalog.ala1.record_page.decoded`).

With a :class:`~sondalog.ala1.record_page.PageSource` (the store, issue 24: a month of rows
of 10,000 loggers was still 3.6 GB compressed) a sealed page leaves RAM once the store has its
rows: RAM keeps a ``None`` in its place, and a read loads the page from the source (the last
pages loaded, fleet-wide, are kept: :func:`~sondalog.ala1.record_page.loaded`). Page ``n``
in RAM is page ``seq // PAGE`` on disk: the first page always starts at a multiple of
:data:`PAGE` (rows before the record's first are empty strings, below the head). A page is
let go only once the store was handed its rows and the line or sampling run that handed them
was not rolled back (:meth:`RecordMemory.take_changes` lets go of what the call before
handed); the page the oldest row is in comes back while rows are dropped from it (a cyclic
record drops about one a row it writes: one load per :data:`PAGE` rows).
"""

from __future__ import annotations

import bisect
import itertools
import operator
from collections.abc import Sequence
from dataclasses import dataclass

from sondalog.ala1.record_page import (
    BULK,
    Page,
    PageSource,
    RecordStore,
    decoded,
    loaded,
    packed,
    read_pages,
)
from sondalog.ala1.record_page import PAGE as PAGE
from sondalog.ala1.record_page import Sealed as Sealed

_COUNTERS = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ"
#: The newest rows (at least KEEP) stay plain strings.
KEEP = 16
#: Pages not yet let go that a record with a source keeps plain (the store has them at the end
#: of the run, and they are let go; beyond, a long run's pages are compressed, as before).
PLAIN_PAGES = 64


def load_record(store: RecordStore) -> RecordMemory:
    """The record ``store`` holds (a ``record_page.PagedStore``: its newest rows in RAM),
    cyclic and of no size until the parameters are applied."""
    # (what isinstance of the runtime protocol checks, without its cost: 60 µs a logger)
    paged = getattr(store, "load_paged_record", None)
    loaded: tuple[list[str] | Sealed, int, bool, bool] = (
        paged() if paged is not None else store.load_record()
    )
    return RecordMemory(*loaded[:2], 0, True, *loaded[2:])


def row_key(row: str) -> str:
    """The record point of a row: ``YYYYMMDDhhmmss.c``."""
    return row[: row.index(",")]


@dataclass(frozen=True, slots=True)
class RecordChanges:
    """What the store must apply: rows with their sequence numbers, and the oldest kept."""

    rows: list[tuple[int, str]]
    head_seq: int
    wrapped: bool
    refused: bool
    #: The record's characters after these changes (the store keeps them: a start needs
    #: not read every row to answer ``read record status``).
    chars: int | None = None
    #: The sequence number after the newest row.
    end: int | None = None

    def size(self) -> str | None:
        """What the store keeps to start without reading the rows: ``HEAD,END,CHARS``."""
        if self.chars is None or self.end is None:
            return None
        return f"{self.head_seq},{self.end},{self.chars}"


@dataclass(frozen=True, slots=True)
class RecordMark:
    """What :meth:`RecordMemory.rollback` goes back to (:meth:`RecordMemory.mark`)."""

    length: int
    head: int
    chars: int
    wrapped: bool
    refused: bool
    staged: int
    #: The head the store was last handed (a commit that failed after the mark did not).
    stored_head: int | None = None


class RecordMemory:
    """Rows of the record in memory order."""

    def __init__(
        self,
        rows: list[str] | Sealed,
        first_seq: int,
        capacity: int,
        cyclic: bool,
        wrapped: bool = False,
        refused: bool = False,
    ) -> None:
        # rows [head:] of the pages' rows then the tail's are in the record; [:head] dropped
        self._source: PageSource | None = None
        if isinstance(rows, Sealed):
            self._pages: list[Page | None] = list(rows.pages)
            self._tail: list[str] = list(rows.tail)
            self._head = rows.head
            self.chars = rows.chars
            self._source = rows.source
        else:
            self._pages, self._tail, self._head = [], list(rows), 0
            self.chars = sum(map(len, rows)) + 2 * len(rows)  # (a restore: 40,000 rows, fast)
        if not self._pages:  # the first page starts at a multiple of PAGE, as on disk
            pad = (first_seq - self._head) % PAGE
            self._tail[:0] = [""] * pad
            self._head += pad
        self._seq0 = first_seq - self._head  # sequence number of the first page's first row
        assert self._seq0 % PAGE == 0, "pages not aligned with the store's"
        self._key = object()  # (this memory's pages among the loaded ones)
        self._evicted = 0  # pages before this one are let go (None) but maybe one
        self._held = -1  # a page let go whose rows are being dropped (:meth:`_length`) ...
        self._held_ends: list[int] = []  # ... and where each of its rows ends
        self.capacity = capacity
        self.cyclic = cyclic
        self.wrapped = wrapped
        self.refused = refused
        self._staged = 0  # rows at the end not yet handed to the store
        self._stored_head = first_seq
        self._seal()
        self._durable = self.next_seq  # the store has every row before this one
        self._evict()

    # -- the rows in RAM ---------------------------------------------------------------------
    def sealed(self) -> Sealed:
        """The rows as RAM holds them, for a copy that a new record starts from (pages let
        go are loaded and sealed again: the store's change, the copy must not)."""
        first = min(self._head // PAGE, len(self._pages))
        pages = tuple(
            packed(page) if page is not None else Page(self._page_rows(n))
            for n, page in enumerate(self._pages[first:], first)
        )
        return Sealed(pages, tuple(self._tail), self._head - first * PAGE, None, self.chars)

    @property
    def paged(self) -> bool:
        """Whether the older pages are in a source (the store), not all in RAM."""
        return self._source is not None

    def _page_rows(self, index: int) -> list[str]:
        """The rows of page ``index`` in RAM, decoded or loaded from the source."""
        page = self._pages[index]
        if page is not None:
            return decoded(page)
        assert self._source is not None
        return loaded(self._key, self._seq0 // PAGE + index, self._source)

    def _evict(self) -> None:
        """Let go of the pages the store has (:attr:`_durable`), with a source."""
        if self._source is None:
            return
        pages = self._pages
        limit = min((self._durable - self._seq0) // PAGE, len(pages))
        for n in range(self._evicted, limit):
            pages[n] = None
        self._evicted = max(self._evicted, limit)
        if self._held >= 0 and self._held != self._head // PAGE:  # its rows are dropped
            self._held, self._held_ends = -1, []

    def _count(self) -> int:
        return len(self._pages) * PAGE + len(self._tail)

    def _seal(self) -> None:
        """Seal the oldest plain rows into pages, leaving at least :data:`KEEP` plain."""
        tail = self._tail
        if len(tail) < PAGE + KEEP:
            return
        full = (len(tail) - KEEP) // PAGE
        # with a source, up to PLAIN_PAGES pages beyond those let go stay plain
        plain = 0 if self._source is None else self._evicted + PLAIN_PAGES - len(self._pages)
        self._pages.extend(Page(tail[n * PAGE : (n + 1) * PAGE], n < plain) for n in range(full))
        del tail[: full * PAGE]

    def _row(self, index: int) -> str:
        sealed = len(self._pages) * PAGE
        if index >= sealed:
            return self._tail[index - sealed]
        return self._page_rows(index // PAGE)[index % PAGE]

    def _length(self, index: int) -> int:
        """The length of row ``index`` (the oldest, being dropped): a page let go comes
        back into RAM while rows are dropped from it (one load per :data:`PAGE` rows)."""
        sealed = len(self._pages) * PAGE
        if index >= sealed:
            return len(self._tail[index - sealed])
        number, at = divmod(index, PAGE)
        page = self._pages[number]
        if page is not None:
            return page.length(at)
        if self._held != number:  # its rows' ends only: nothing compressed again
            self._held, self._held_ends = (
                number,
                list(itertools.accumulate(map(len, self._page_rows(number)))),
            )
        ends = self._held_ends
        return ends[at] - (ends[at - 1] if at else 0)

    def _slice(self, begin: int, end: int) -> list[str]:
        """Rows ``begin`` to ``end`` (indices in RAM, ``end`` excluded)."""
        sealed = len(self._pages) * PAGE
        out: list[str] = []
        index = begin
        many: dict[int, list[str]] = {}  # many pages let go: read in one go, not kept
        if self._source is not None and min(end, sealed) - begin > BULK * PAGE:
            first = self._seq0 // PAGE
            many = read_pages(self._source, first + begin // PAGE, first + end // PAGE)
        while index < min(end, sealed):
            page, offset = divmod(index, PAGE)
            stop = min(end - page * PAGE, PAGE)
            rows = many.get(self._seq0 // PAGE + page) if self._pages[page] is None else None
            out.extend((rows or self._page_rows(page))[offset:stop])
            index = page * PAGE + stop
        if end > sealed:
            out.extend(self._tail[max(begin, sealed) - sealed : end - sealed])
        return out

    # -- reading ---------------------------------------------------------------------------
    def __len__(self) -> int:
        return self._count() - self._head

    def rows(self, start: int = 0, count: int | None = None) -> list[str]:
        """``count`` rows from position ``start`` (0 = the oldest)."""
        begin = self._head + start
        total = self._count()
        end = total if count is None else min(total, begin + count)
        return self._slice(begin, end) if begin < end else []

    def position_at_or_after(self, point: str) -> int:
        """Position of the oldest row whose point is at or after ``point`` (a prefix)."""
        return self._search(point, strictly=False)

    def position_after(self, point: str) -> int:
        """Position of the oldest row whose point comes after ``point``."""
        return self._search(point, strictly=True)

    def _search(self, point: str, *, strictly: bool) -> int:
        lo, hi = self._head, self._count()
        if lo == hi:
            return 0
        # rows are in time order unless the clock was set back: bisect when the keys ascend
        if row_key(self._row(lo)) <= row_key(self._row(hi - 1)):
            keys = _KeyView(self)
            found = (bisect.bisect_right if strictly else bisect.bisect_left)(keys, point, lo, hi)
            if self._ordered_around(found):
                return found - self._head
        for i in range(lo, hi):
            key = row_key(self._row(i))
            if key > point or (not strictly and key >= point):
                return i - self._head
        return hi - self._head

    def _ordered_around(self, index: int) -> bool:
        row = self._row
        return all(
            row_key(row(i - 1)) <= row_key(row(i))
            for i in range(max(self._head + 1, index - 1), min(self._count(), index + 2))
        )

    def status(self) -> str:
        """§6.6.5: ``chars,fraction,STATE``."""
        if self.cyclic and self.wrapped:
            return "0,1.00,FULL"
        if self.refused:
            return f"{self.chars},1.00,FULL"
        if not len(self):
            return "0,0.00,CLEAR"
        fraction = int(self.chars * 100 / self.capacity + 0.5) / 100 if self.capacity else 1.0
        return f"{self.chars},{fraction:.2f},FILLING"

    # -- writing ---------------------------------------------------------------------------
    def append(self, stamp: str, body: str) -> str | None:
        """Store a row written at ``stamp`` (YYYYMMDDhhmmss); None if it does not fit."""
        row = f"{stamp}.{_COUNTERS[self._counter(stamp)]},{body}"
        size = len(row) + 2
        if size > self.capacity:
            self.refused = not self.cyclic
            return None
        if self.chars + size > self.capacity:
            if not self.cyclic:
                self.refused = True
                return None
            while self.chars + size > self.capacity:
                self.chars -= self._length(self._head) + 2
                self._head += 1
            self.wrapped = True
        self._tail.append(row)
        self._staged += 1
        self.chars += size
        self._seal()
        return row

    def _counter(self, stamp: str) -> int:
        """A row's counter (§6.6.5): one more than the newest row's of the same second."""
        if len(self):
            last = self._tail[-1] if self._tail else self._row(self._count() - 1)
            if last.startswith(stamp) and last[14] == ".":
                return min(_COUNTERS.index(last[15]) + 1, len(_COUNTERS) - 1)
        return 0

    def append_many(self, stamps: list[str], bodies: list[str]) -> None:
        """:meth:`append` of each row in turn, in one pass (issue 24: a stretch of instants;
        why: docs/decisions.md, fifth round). Anything but rows of ascending seconds that a
        cyclic record takes or a linear one takes all of goes row by row."""
        rows = [f"{stamp}.0,{body}" for stamp, body in zip(stamps, bodies, strict=True)]
        sizes, capacity = sum(map(len, rows)) + 2 * len(rows), self.capacity
        fits = self.chars + sizes <= capacity or (
            self.cyclic and max(map(len, rows), default=0) + 2 <= capacity
        )
        ascending = not any(map(operator.ge, stamps, itertools.islice(stamps, 1, None)))
        if not rows or not fits or not ascending or self._counter(stamps[0]):
            for stamp, body in zip(stamps, bodies, strict=True):
                self.append(stamp, body)
            return
        self._tail.extend(rows)
        self._staged += len(rows)
        self.chars += sizes
        if self.chars > capacity:
            self._drop(self.chars - capacity)
            self.wrapped = True
        self._seal()

    def _drop(self, excess: int) -> None:
        """Drop the oldest rows until ``excess`` characters (with CR LF) or more are gone."""
        head, dropped = self._head, 0
        sealed = len(self._pages) * PAGE
        while dropped < excess and head < sealed:
            number, at = divmod(head, PAGE)
            page = self._pages[number]
            if page is None:
                self._length(head)  # (the page let go comes back: its rows' ends)
            ends: Sequence[int] = self._held_ends if page is None else page.ends
            while dropped < excess and at < PAGE:
                dropped += ends[at] - (ends[at - 1] if at else 0) + 2
                at += 1
            head = number * PAGE + at
        tail = self._tail
        while dropped < excess:
            dropped += len(tail[head - sealed]) + 2
            head += 1
        self._head = head
        self.chars -= dropped

    def load_rows(self, rows: list[str]) -> None:
        """Append rows as they are (an image written by XMODEM, §6.16.3)."""
        for row in rows:
            self._tail.append(row)
            self._staged += 1
            self.chars += len(row) + 2
        self._seal()

    def clear(self) -> None:
        """§6.6.5.1: erase every row; the state returns to CLEAR."""
        self._head = self._count()
        self.chars = 0
        self.wrapped = False
        self.refused = False

    def reconfigure(self, capacity: int, cyclic: bool) -> None:
        """New size (after clearing, §6.15.1) or type (only while empty, §6.6.4)."""
        self.capacity = capacity
        self.cyclic = cyclic

    # -- transactions ------------------------------------------------------------------------
    def mark(self) -> RecordMark:
        return RecordMark(
            self._count(),
            *(self._head, self.chars, self.wrapped, self.refused, self._staged, self._stored_head),
        )

    def rollback(self, mark: RecordMark) -> None:
        sealed = len(self._pages) * PAGE
        if mark.length < sealed:  # rows sealed since the mark: their pages become plain
            first = mark.length // PAGE
            pages = range(first, len(self._pages))
            rows = [row for n in pages for row in self._page_rows(n)]
            del self._pages[first:]
            self._tail = rows + self._tail
            sealed = first * PAGE
            self._evicted = min(self._evicted, first)
            self._held = -1 if self._held >= first else self._held
        del self._tail[mark.length - sealed :]
        self._head, self.chars = mark.head, mark.chars
        self.wrapped, self.refused, self._staged = mark.wrapped, mark.refused, mark.staged
        if mark.stored_head is not None:
            self._stored_head = mark.stored_head
        # (a commit that failed: the rows staged at the mark are not the store's)
        self._durable = min(self._durable, self._seq0 + mark.length - mark.staged)

    def take_changes(self) -> RecordChanges | None:
        """What changed since the last call; compacts dropped rows away. The rows handed
        by the call before are the store's now (this line or run goes on after it)."""
        self._evict()
        head_seq = self._seq0 + self._head
        if not self._staged and head_seq == self._stored_head:
            return None
        total = self._count()
        first_new = total - self._staged
        first_kept = max(first_new, self._head)  # rows dropped again before reaching the store
        rows = self._slice(first_kept, total)
        new_rows = list(zip(range(self._seq0 + first_kept, self._seq0 + total), rows, strict=True))
        changes = RecordChanges(
            new_rows, head_seq, self.wrapped, self.refused, self.chars, self._seq0 + total
        )
        self._staged = 0
        self._stored_head = head_seq
        self._durable = self._seq0 + total
        if self._head > 4096 and self._head * 2 > total:
            pages = min(self._head // PAGE, len(self._pages))  # whole pages of dropped rows
            del self._pages[:pages]
            self._seq0 += pages * PAGE
            self._head -= pages * PAGE
            self._evicted = max(self._evicted - pages, 0)
            self._held = max(self._held - pages, -1)
        return changes

    @property
    def next_seq(self) -> int:
        return self._seq0 + self._count()


class _KeyView:
    """Row keys as a sequence, for bisect."""

    __slots__ = ("memory",)

    def __init__(self, memory: RecordMemory) -> None:
        self.memory = memory

    def __getitem__(self, index: int) -> str:
        return row_key(self.memory._row(index))

    def __len__(self) -> int:
        return self.memory._count()
