"""Downsampling keeps within the point budget and keeps every series' extremes and gaps."""

from __future__ import annotations

import math
import sqlite3
from datetime import datetime, timedelta

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect import blocks_fill, blocks_sql
from sondalog.collect.model import Reading
from sondalog.collect.schema import SQLITE_DDL
from sondalog.web import series, store
from sondalog.web.series import break_gaps
from sondalog.web.times import to_epoch

values = st.one_of(st.none(), st.floats(-1e6, 1e6, allow_nan=False))


@settings(max_examples=40, deadline=None)
@given(
    steps=st.lists(st.sampled_from([1, 60, 60, 60, 600, 7200]), min_size=1, max_size=400),
    vals=st.lists(values, min_size=400, max_size=400),
    channels=st.integers(1, 3),
    max_points=st.sampled_from([10, 40, 100, 2000]),
    kept=st.sampled_from(["rows", "blocks by batch", "blocks filled"]),
)
def test_budget_extremes_and_gaps(
    steps: list[int], vals: list[float | None], channels: int, max_points: int, kept: str
) -> None:
    conn = sqlite3.connect(":memory:", isolation_level=None)
    conn.executescript(SQLITE_DDL)
    if kept == "blocks by batch":
        with conn:
            conn.execute("BEGIN")
            blocks_sql.ensure_sqlite(conn)  # an empty store: nothing to fill
    t = datetime(2026, 1, 1)
    rows = []
    for i, step in enumerate(steps):
        t += timedelta(seconds=step)
        stamp = t.strftime("%Y-%m-%dT%H:%M:%S")
        rows += [
            ("L", ch, stamp, 0, 1, vals[i], None, f"c{ch}", "u") for ch in range(1, channels + 1)
        ]
    conn.executemany(
        "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, "
        "value, text, name, unit) VALUES (?,?,?,?,?,?,?,?,?)",
        rows,
    )
    if kept == "blocks by batch":
        conn.execute("BEGIN")
        blocks_sql.after_batch_sqlite(
            conn, [Reading(r[0], r[1], datetime.fromisoformat(r[2]), 0, 1, r[5]) for r in rows]
        )
        conn.execute("COMMIT")
    if kept == "blocks filled":
        while blocks_fill.fill_step_sqlite(conn):
            pass
    db = store.of_file(conn)
    assert db.has_blocks == (kept != "rows")
    lo, hi = "2026-01-01T00:00:00", t.strftime("%Y-%m-%dT%H:%M:%S")
    got, width = series.load(db, "L", store.channels(db, "L"), lo, hi, max_points)
    assert len(got) == channels
    stored = [v for v in vals[: len(steps)] if v is not None]
    readings = {(to_epoch(r[2]), r[5]) for r in rows if r[1] == 1 and r[5] is not None}
    for s in got:
        # every value shown is a reading, at its own time (so within the range, in order)
        shown_points = {(math.floor(x), v) for x, v in zip(s.t, s.v, strict=True) if v is not None}
        assert shown_points <= readings
        assert len(s.t) == len(s.v) <= max_points
        assert s.t == sorted(s.t)
        shown = [v for v in s.v if v is not None]
        assert (min(shown), max(shown)) == (min(stored), max(stored)) if stored else not shown
        if width is None:  # every stored reading is there, NULLs included
            assert len([v for v in s.v if v is not None]) == len(stored)
    if width is None:
        assert len(steps) <= max_points
    if len(steps) * 2 <= max_points:  # even a null after every reading fits
        assert width is None


def test_break_gaps_puts_one_null_in_a_long_pause() -> None:
    t = [0.0, 60, 120, 180, 1000, 1060]
    v: list[float | None] = [1.0, 2, 3, 4, 5, 6]
    break_gaps(t, v)
    assert t == [0, 60, 120, 180, 590, 1000, 1060]
    assert v == [1, 2, 3, 4, None, 5, 6]
    t2, v2 = [0.0, 60, 120], [None, 1.0, None]
    break_gaps(t2, v2)
    assert (t2, v2) == ([0, 60, 120], [None, 1.0, None])


def test_downsampled_extremes_keep_their_times_and_order() -> None:
    """A falling series: each bucket's maximum comes before its minimum, and the last point
    is the last reading, not half a bucket after it (issue 26)."""
    conn = sqlite3.connect(":memory:")
    conn.executescript(SQLITE_DDL)
    t0 = datetime(2026, 1, 1)
    rows = [
        ("L", 1, (t0 + timedelta(minutes=i)).strftime("%Y-%m-%dT%H:%M:%S"), 0, 1, -i, None)
        for i in range(1000)
    ]
    conn.executemany(
        "INSERT INTO readings (logger, channel, time, counter, type, value, text) "
        "VALUES (?,?,?,?,?,?,?)",
        rows,
    )
    lo, hi = rows[0][2], rows[-1][2]
    db = store.of_file(conn)
    (s,), width = series.load(db, "L", store.channels(db, "L"), lo, hi, 40)
    assert width is not None
    assert s.v == sorted(s.v, reverse=True)  # falling, as the readings do
    assert s.t[0] == to_epoch(lo) and s.t[-1] == to_epoch(hi)
    assert s.v[-1] == -999
