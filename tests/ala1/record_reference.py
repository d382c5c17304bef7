"""The record memory as it was before its rows were sealed into pages (issue 24): one
string a row. The reference tests/ala1/test_record_pages.py compares RecordMemory with."""

from __future__ import annotations

import bisect

from sondalog.ala1.record import _COUNTERS, RecordChanges, RecordMark, row_key


class ListRecordMemory:
    """Rows of the record in memory order."""

    def __init__(
        self,
        rows: list[str],
        first_seq: int,
        capacity: int,
        cyclic: bool,
        wrapped: bool = False,
        refused: bool = False,
    ) -> None:
        self._rows = rows  # rows[head:] are in the record; rows[:head] were dropped
        self._seq0 = first_seq  # sequence number of _rows[0]
        self._head = 0
        self.capacity = capacity
        self.cyclic = cyclic
        self.wrapped = wrapped
        self.refused = refused
        self.chars = sum(len(r) + 2 for r in rows)
        self._staged = 0  # rows at the end not yet handed to the store
        self._stored_head = first_seq

    # -- reading ---------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._rows) - self._head

    def rows(self, start: int = 0, count: int | None = None) -> list[str]:
        """``count`` rows from position ``start`` (0 = the oldest)."""
        begin = self._head + start
        end = len(self._rows) if count is None else min(len(self._rows), begin + count)
        return self._rows[begin:end]

    def position_at_or_after(self, point: str) -> int:
        """Position of the oldest row whose point is at or after ``point`` (a prefix)."""
        return self._search(point, strictly=False)

    def position_after(self, point: str) -> int:
        """Position of the oldest row whose point comes after ``point``."""
        return self._search(point, strictly=True)

    def _search(self, point: str, *, strictly: bool) -> int:
        rows = self._rows
        lo, hi = self._head, len(rows)
        if lo == hi:
            return 0
        # rows are in time order unless the clock was set back: bisect when the keys ascend
        if row_key(rows[lo]) <= row_key(rows[hi - 1]):
            keys = _KeyView(rows)
            found = (bisect.bisect_right if strictly else bisect.bisect_left)(keys, point, lo, hi)
            if self._ordered_around(found):
                return found - self._head
        for i in range(lo, hi):
            key = row_key(rows[i])
            if key > point or (not strictly and key >= point):
                return i - self._head
        return hi - self._head

    def _ordered_around(self, index: int) -> bool:
        rows = self._rows
        return all(
            row_key(rows[i - 1]) <= row_key(rows[i])
            for i in range(max(self._head + 1, index - 1), min(len(rows), index + 2))
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
        counter = 0
        if len(self):
            last = self._rows[-1]
            if last.startswith(stamp) and last[14] == ".":
                counter = min(_COUNTERS.index(last[15]) + 1, len(_COUNTERS) - 1)
        row = f"{stamp}.{_COUNTERS[counter]},{body}"
        size = len(row) + 2
        if size > self.capacity:
            self.refused = not self.cyclic
            return None
        if self.chars + size > self.capacity:
            if not self.cyclic:
                self.refused = True
                return None
            while self.chars + size > self.capacity:
                self.chars -= len(self._rows[self._head]) + 2
                self._head += 1
            self.wrapped = True
        self._rows.append(row)
        self._staged += 1
        self.chars += size
        return row

    def load_rows(self, rows: list[str]) -> None:
        """Append rows as they are (an image written by XMODEM, §6.16.3)."""
        for row in rows:
            self._rows.append(row)
            self._staged += 1
            self.chars += len(row) + 2

    def clear(self) -> None:
        """§6.6.5.1: erase every row; the state returns to CLEAR."""
        self._head = len(self._rows)
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
            len(self._rows),
            *(self._head, self.chars, self.wrapped, self.refused, self._staged, self._stored_head),
        )

    def rollback(self, mark: RecordMark) -> None:
        del self._rows[mark.length :]
        self._head, self.chars = mark.head, mark.chars
        self.wrapped, self.refused, self._staged = mark.wrapped, mark.refused, mark.staged
        if mark.stored_head is not None:
            self._stored_head = mark.stored_head

    def take_changes(self) -> RecordChanges | None:
        """What changed since the last call; compacts dropped rows away."""
        head_seq = self._seq0 + self._head
        if not self._staged and head_seq == self._stored_head:
            return None
        first_new = len(self._rows) - self._staged
        first_kept = max(first_new, self._head)  # rows dropped again before reaching the store
        new_rows = [(self._seq0 + i, self._rows[i]) for i in range(first_kept, len(self._rows))]
        end = self._seq0 + len(self._rows)
        changes = RecordChanges(new_rows, head_seq, self.wrapped, self.refused, self.chars, end)
        self._staged = 0
        self._stored_head = head_seq
        if self._head > 4096 and self._head * 2 > len(self._rows):
            del self._rows[: self._head]
            self._seq0 += self._head
            self._head = 0
        return changes

    @property
    def next_seq(self) -> int:
        return self._seq0 + len(self._rows)


class _KeyView:
    """Row keys as a sequence, for bisect."""

    __slots__ = ("rows",)

    def __init__(self, rows: list[str]) -> None:
        self.rows = rows

    def __getitem__(self, index: int) -> str:
        return row_key(self.rows[index])

    def __len__(self) -> int:
        return len(self.rows)
