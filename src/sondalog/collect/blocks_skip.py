"""Which readings of a batch can change the dashboard's block extremes (issue 24).

The SQLite store merges every batch's rows into ``readings_extremes``
(:func:`sondalog.collect.blocks_sql.after_batch_sqlite`): per row, 16 blocks (4 channels, 4
sizes) for a collector's usual contact of one new row. Most rows change none of them: a value
that is neither the smallest nor the largest of its half hour so far cannot be the smallest
or largest of its day either.

:class:`SentBlocks` remembers, per logger and channel, the extremes of the finest block
(:data:`~sondalog.collect.blocks_rule.SIZES` ``[0]``) that this store has merged so far, and
:meth:`SentBlocks.news` keeps only the readings that would change them by the rule of the
blocks (:mod:`sondalog.collect.blocks_rule`: a smaller or larger value wins, on a tie the
earlier time, NULL loses to any value, between NULLs the later time). A reading that does not
change the finest block's extremes as merged cannot change the stored block (which took
them, or better ones), nor any coarser block over it: dropping it stores exactly the same
extremes, since the rule picks by a total order (which is associative, commutative and
idempotent). What is remembered must have been committed: the store calls
:meth:`SentBlocks.forget` when a transaction fails (:func:`transaction`). Only batches whose
every row was stored go through :meth:`SentBlocks.news`; a batch with duplicates has its
blocks read back from the stored rows (which hold at least what was merged), and what was
remembered stays true.
"""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterable, Iterator
from datetime import datetime
from typing import Any

from sondalog.collect.blocks_rule import SIZES, epoch, take
from sondalog.collect.model import Reading

#: Slots a channel takes in a logger's list: block start, vmin, tmin, vmax, tmax.
_SLOTS = 5


class SentBlocks:
    """Per logger, a flat list of its channels' finest block extremes as merged
    (``[start, vmin, tmin, vmax, tmax] * channels``, channel N at ``(N - 1) * 5``; a start of
    None: nothing merged): ten thousand loggers of 4 channels keep about 5 MB."""

    def __init__(self) -> None:
        self._by: dict[str, list[Any]] = {}

    def forget(self) -> None:
        """Nothing is known any more (a transaction that merged rows failed)."""
        self._by.clear()

    def news(self, batch: Iterable[Reading]) -> list[Reading]:
        """The readings of ``batch`` (channels > 0) that change a finest block's extremes as
        merged so far, taking them as merged (the caller merges them in its transaction)."""
        size = SIZES[0]
        by = self._by
        out: list[Reading] = []
        last: datetime | None = None
        sec = start = 0
        for r in batch:
            channel = r.channel
            if channel <= 0:
                continue
            if r.time != last:
                last, sec = r.time, epoch(r.time)
                start = sec - sec % size
            at = (channel - 1) * _SLOTS
            c = by.get(r.logger)
            if c is None:
                c = by[r.logger] = [None] * (at + _SLOTS)
            elif len(c) <= at:
                c.extend([None] * (at + _SLOTS - len(c)))
            v = r.value
            if c[at] != start:  # a block not merged yet (or another one than the last)
                c[at : at + _SLOTS] = (start, v, sec, v, sec)
                out.append(r)
            elif take(c, v, sec, at + 1, -1) | take(c, v, sec, at + 3, 1):
                out.append(r)
        return out


@contextlib.contextmanager
def transaction(db: sqlite3.Connection, sent: SentBlocks | None) -> Iterator[None]:
    """``with db:`` (one transaction); what ``sent`` took is forgotten when it fails (rolled
    back: its rows are merged again at the next try)."""
    try:
        with db:
            yield
    except BaseException:
        if sent is not None:
            sent.forget()
        raise
