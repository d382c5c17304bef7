"""A logger's plot data: one series per channel, at most ``max_points`` points each.

A range with at most ``max_points`` rows per channel is sent as it is (unless the gaps'
nulls would take a series over the budget). A larger one is cut into ``max_points // 2``
equal buckets and each series sends its smallest and largest value per bucket (min/max
downsampling: peaks survive any zoom level); a type-6 channel (bars, §6.5.6.4) sends its
largest count per bucket. A "no valid value" reading (NULL) stays a gap, and so does a
pause in the data longer than three times the series' usual step: a ``null`` is put there
so the line breaks instead of bridging it. Each series carries its own times (``t``, seconds on the
logger's clock read as UTC) and values (``v``); the browser joins them.
"""

from __future__ import annotations

import math
import sqlite3
from dataclasses import dataclass, field
from itertools import pairwise
from statistics import median
from typing import Any

from . import store
from .times import from_epoch, to_epoch


@dataclass
class Series:
    """One channel's points."""

    channel: store.Channel
    t: list[float] = field(default_factory=list)
    v: list[float | None] = field(default_factory=list)

    def as_json(self) -> dict[str, Any]:
        return {
            "channel": self.channel.channel,
            "name": self.channel.name,
            "unit": self.channel.unit,
            "kind": self.channel.kind,
            "t": self.t,
            "v": self.v,
        }


def break_gaps(t: list[float], v: list[float | None]) -> None:
    """Insert a ``null`` midway where consecutive points are more than 3 usual steps apart.

    The usual step is the median one; at most one null per gap; modifies ``t`` and ``v``.
    """
    if len(t) < 3:
        return
    usual = median(b - a for a, b in pairwise(t))
    if usual <= 0:
        return
    out_t: list[float] = [t[0]]
    out_v: list[float | None] = [v[0]]
    for i in range(1, len(t)):
        if t[i] - t[i - 1] > 3 * usual and out_v[-1] is not None:
            out_t.append((t[i - 1] + t[i]) / 2)
            out_v.append(None)
        out_t.append(t[i])
        out_v.append(v[i])
    t[:] = out_t
    v[:] = out_v


def load(
    conn: sqlite3.Connection,
    logger: str,
    chans: list[store.Channel],
    lo: str,
    hi: str,
    max_points: int,
) -> tuple[list[Series], float | None]:
    """The series of ``logger`` in ``[lo, hi]`` and the bucket width (None: not downsampled)."""
    by_ch = {c.channel: Series(c) for c in chans}
    # raw when every series has at most max_points rows; past this many rows in all, some
    # channel has more (pigeonhole), so counting stops there
    cap = max_points * max(1, len(by_ch)) + 1
    per_channel, capped = store.counts(conn, logger, lo, hi, cap)
    for ch in per_channel:
        if ch not in by_ch:
            by_ch[ch] = Series(store.Channel(ch, None, None))
    largest = max(per_channel.values(), default=0)
    width: float | None = None
    if not capped and largest <= max_points:
        _raw(conn, logger, lo, hi, by_ch)
        if all(len(s.t) <= max_points for s in by_ch.values()):
            return [by_ch[k] for k in sorted(by_ch)], None
        for s in by_ch.values():  # the gaps' nulls went over the budget
            s.t.clear()
            s.v.clear()
    width = _downsampled(conn, logger, lo, hi, max_points // 2, by_ch)
    return [by_ch[k] for k in sorted(by_ch)], width


def _raw(conn: sqlite3.Connection, logger: str, lo: str, hi: str, by_ch: dict[int, Series]) -> None:
    prev_time = ""
    seen_in_second: dict[int, int] = {}
    base = 0
    for time, counter, ch, value in store.raw(conn, logger, lo, hi):
        if time != prev_time:
            prev_time, base, seen_in_second = time, to_epoch(time), {}
        # rows written in the same second (counter > first) sit a millisecond apart
        slot = seen_in_second.setdefault(counter, len(seen_in_second))
        s = by_ch[ch]
        s.t.append(base + slot / 1000 if slot else base)
        s.v.append(value)
    for s in by_ch.values():
        break_gaps(s.t, s.v)


def _downsampled(
    conn: sqlite3.Connection,
    logger: str,
    lo: str,
    hi: str,
    buckets: int,
    by_ch: dict[int, Series],
) -> float:
    start, end = to_epoch(lo), to_epoch(hi) + 1
    width = max(1, math.ceil((end - start) / buckets))
    edges = [from_epoch(start + i * width) for i in range(math.ceil((end - start) / width) + 1)]
    cells: dict[int, list[tuple[int, float | None, float | None]]] = {}
    for i, ch, vmin, vmax in store.bucketed(conn, logger, edges):
        cells.setdefault(ch, []).append((i, vmin, vmax))
    for ch, rows in cells.items():
        s = by_ch[ch]
        rows.sort()
        bars = s.channel.kind == "bars"
        for i, vmin, vmax in rows:
            x = start + i * width
            if bars or vmin == vmax:
                s.t.append(x)
                s.v.append(vmax)
            else:
                s.t += [x, x + width / 2]
                s.v += [vmin, vmax]
        # a pause spans at least one empty bucket, so the nulls keep within 2 per bucket
        break_gaps(s.t, s.v)
    return float(width)
