"""A logger's plot data: one series per channel, at most ``max_points`` points each.

A range with at most ``max_points`` rows per channel is sent as it is (unless the gaps'
nulls would take a series over the budget). A larger one is cut into ``max_points // 2``
equal buckets and each series sends its smallest and largest value per bucket (min/max
downsampling: peaks survive any zoom level), each at the time of a reading that has it and
in their order in time, so no point lies outside the range or after the last reading; a
type-6 channel (bars, §6.5.6.4) sends its largest count per bucket. A "no valid value"
reading (NULL) stays a gap, and so does a pause in the data longer than three times the
series' usual step (``step``, sent along for the live rows the browser appends): a ``null``
is put there so the line breaks instead of bridging it. Each series carries its own times
(``t``, seconds on the logger's clock read as UTC) and values (``v``); the browser joins them.

The buckets (:func:`.blocks.plan`: on the grid of a block size for a long range) and their
extremes come from :func:`.blocks.by_channel`: from the per-block extremes the sinks keep
where they are complete (a year in tens of milliseconds), else from the rows; the same
answer either way, on SQLite and PostgreSQL.
"""

from __future__ import annotations

import operator
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from statistics import median
from typing import Any

from . import blocks, store
from .times import shift, to_epoch


@dataclass
class Series:
    """One channel's points."""

    channel: store.Channel
    t: list[float] = field(default_factory=list)
    v: list[float | None] = field(default_factory=list)
    #: The usual step (seconds) a pause is measured against (None: under 3 points); the
    #: browser breaks the live rows it appends at the same pauses as a fresh load.
    step: float | None = None

    def as_json(self) -> dict[str, Any]:
        return {
            "channel": self.channel.channel,
            "name": self.channel.name,
            "unit": self.channel.unit,
            "kind": self.channel.kind,
            "decimals": self.channel.decimals,
            "t": self.t,
            "v": self.v,
            "step": self.step,
        }


def break_gaps(
    t: list[float], v: list[float | None], may_break: Sequence[bool] | None = None
) -> float | None:
    """Insert a ``null`` midway where consecutive points are more than 3 usual steps apart.

    The usual step is the median one (returned; None under 3 points); at most one null per
    gap; ``may_break[i]`` False forbids one before point ``i``; modifies ``t`` and ``v``.
    """
    if len(t) < 3:
        return None
    usual = median(b - a for a, b in pairwise(t))
    if usual <= 0:
        return None
    out_t: list[float] = [t[0]]
    out_v: list[float | None] = [v[0]]
    for i in range(1, len(t)):
        allowed = may_break is None or may_break[i]
        if allowed and t[i] - t[i - 1] > 3 * usual and out_v[-1] is not None:
            out_t.append((t[i - 1] + t[i]) / 2)
            out_v.append(None)
        out_t.append(t[i])
        out_v.append(v[i])
    t[:] = out_t
    v[:] = out_v
    return usual


def answer(
    db: store.Db, logger: str, lo: str | None, hi: str | None, max_points: int, span_s: float
) -> dict[str, Any]:
    """The plot's answer (``/api/loggers/{logger}/series``): ``[lo, hi]``, or up to the last
    reading (``hi`` None: the plot follows the new rows) and ``span_s`` back from ``hi``
    (``lo`` None: not before the first reading)."""
    first, last = store.first_and_last(db, logger)
    to = hi or last or "1970-01-01T00:00:00"
    frm = lo or max(shift(to, -span_s), min(first or to, to))
    chans = store.channels(db, logger)
    got, width = load(db, logger, chans, frm, to, max_points)
    return {
        "logger": logger,
        "from": frm,
        "to": to,
        "x_from": to_epoch(frm),
        "x_to": to_epoch(to),
        "following": hi is None,
        "last": last,
        "first": first,
        "downsampled": width is not None,
        "bucket_s": width,
        "series": [s.as_json() for s in got],
    }


def load(
    db: store.Db,
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
    per_channel: dict[int, int] = {}
    # a long range is downsampled without its channels counted: those with rows in the
    # range come with the buckets
    capped = store.reaches(db, logger, lo, hi, cap)
    if not capped:
        per_channel, capped = store.counts(db, logger, lo, hi, cap)
    for ch in per_channel:
        if ch not in by_ch:
            by_ch[ch] = Series(store.Channel(ch, None, None))
    largest = max(per_channel.values(), default=0)
    width: float | None = None
    if not capped and largest <= max_points:
        _raw(db, logger, lo, hi, by_ch)
        if all(len(s.t) <= max_points for s in by_ch.values()):
            return [by_ch[k] for k in sorted(by_ch)], None
        for s in by_ch.values():  # the gaps' nulls went over the budget
            s.t.clear()
            s.v.clear()
    width = _downsampled(db, logger, lo, hi, max_points // 2, by_ch)
    return [by_ch[k] for k in sorted(by_ch)], width


def _raw(db: store.Db, logger: str, lo: str, hi: str, by_ch: dict[int, Series]) -> None:
    prev_time = ""
    seen_in_second: dict[int, int] = {}
    base = 0
    for time, counter, ch, value in store.raw(db, logger, lo, hi):
        if time != prev_time:
            prev_time, base, seen_in_second = time, to_epoch(time), {}
        # rows written in the same second (counter > first) sit a millisecond apart
        slot = seen_in_second.setdefault(counter, len(seen_in_second))
        s = by_ch[ch]
        s.t.append(base + slot / 1000 if slot else base)
        s.v.append(value)
    for s in by_ch.values():
        s.step = break_gaps(s.t, s.v)


def _downsampled(
    db: store.Db,
    logger: str,
    lo: str,
    hi: str,
    buckets: int,
    by_ch: dict[int, Series],
) -> float:
    p = blocks.plan(lo, hi, buckets)
    for ch, got in blocks.by_channel(db, logger, p):
        s = by_ch.setdefault(ch, Series(store.Channel(ch, None, None)))
        s.step = _break_at(s.t, s.v, _points(got, s.channel.kind == "bars", s.t, s.v))
    return float(p.width)


def _points(
    got: Iterable[blocks.Bucket], bars: bool, t: list[float], v: list[float | None]
) -> list[int]:
    """A series' points of its buckets ``got`` (in order) appended to ``t`` and ``v``, and
    the points a pause may be broken before: only across an empty bucket, so the nulls keep
    within 2 per bucket."""
    jumps: list[int] = []
    last = 1 << 62  # the first bucket is no jump
    for _, k, vmin, tmin, vmax, tmax in got:
        # a bucket's points: its smallest and largest value at the times of readings that
        # have them, in time order (so every point lies in the range, where a reading
        # was); bars: the largest only
        if k - last > 1:
            jumps.append(len(t))
        last = k
        if bars or vmin == vmax:
            t.append(tmax)
            v.append(vmax)
        elif tmin == tmax:  # two rows of one second (counters): a millisecond apart
            t += (tmin, tmax + 0.001)
            v += (vmin, vmax)
        elif tmin < tmax:
            t += (tmin, tmax)
            v += (vmin, vmax)
        else:
            t += (tmax, tmin)
            v += (vmax, vmin)
    return jumps


def _break_at(t: list[float], v: list[float | None], at: list[int]) -> float | None:
    """:func:`break_gaps` with ``may_break`` true only at the points ``at`` (few: the
    series' pauses), without going through every point again."""
    if len(t) < 3:
        return None
    usual: float = median(map(operator.sub, t[1:], t[:-1]))
    if usual <= 0:
        return None
    gaps = [i for i in at if t[i] - t[i - 1] > 3 * usual and v[i - 1] is not None]
    for i in reversed(gaps):
        t.insert(i, (t[i - 1] + t[i]) / 2)
        v.insert(i, None)
    return usual
