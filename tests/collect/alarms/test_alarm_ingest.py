"""``Alarms.ingest`` (the compiled fast path of issue 21) answers exactly as ``Alarms.reading``.

Random rule sets (threshold above/below with clear and for, stuck with for and tolerance,
step with for; logger globs; channels by number, by name glob, or all) and random chunks of
the collector's readings (late and old rows, the same reading twice, rows of one time,
None values, NaN and infinities, counters, with and without a UTC time, several sources):
the transitions of every chunk, the alarms each chunk changed and the exported states must
be the same from ``ingest(source, readings)`` as from ``readings(Sample.of(...))``, also
when both start from states a previous run exported.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import fields, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from alarm_helpers import plan_of
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect.alarms import AlarmPlan, AlarmRecord, Alarms, AlarmStore, Rule, Sample
from sondalog.collect.alarms.progress import unpack
from sondalog.collect.model import Reading

T0 = datetime(2026, 1, 1)
LOGGERS = ("F01", "F02", "G1")
NAMES = (None, "T1", "T2", "Air")
VALUES = (0.0, 0.5, 1.0, 1.0005, 2.0, 2.5, -1.0, 10.0, math.nan, math.inf, -math.inf)


@st.composite
def rules(draw: st.DrawFn, kinds: tuple[str, ...] = ("threshold", "stuck", "step")) -> AlarmPlan:
    out = []
    for i in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(kinds))
        where = draw(st.sampled_from(["number", "name", "all"]))
        fields: dict[str, object] = {
            "logger": draw(st.sampled_from(["*", "F*", "F01", "G?", "X*"])),
            "source": draw(st.sampled_from(["*", "*", "s1", "s?"])),
            "count": draw(st.integers(0, 4)),
        }
        if where == "number":
            fields["channel"] = draw(st.integers(1, 3))
        elif where == "name":
            fields["channel_name"] = draw(st.sampled_from(["T*", "Air", "T1", "*"]))
        if kind == "threshold":
            limit = draw(st.sampled_from([0.5, 1.0, 2.0, 2.4]))
            direction = draw(st.sampled_from(["above", "below"]))
            gap = draw(st.sampled_from([0.0, 0.5, 1.0]))
            fields |= {
                "direction": direction,
                "limit": limit,
                "clear": limit - gap if direction == "above" else limit + gap,
                "clear_count": draw(st.integers(0, 3)),
            }
        elif kind == "stuck":
            fields["tolerance"] = draw(st.sampled_from([0.0, 0.001, 0.5]))
        else:
            fields["step"] = draw(st.sampled_from([0.0, 0.4, 1.5]))
        out.append(Rule(f"r{i}", kind, **fields))  # type: ignore[arg-type]
    return AlarmPlan(tuple(out))


@st.composite
def chunks(draw: st.DrawFn) -> list[tuple[str, list[Reading]]]:
    out = []
    for _ in range(draw(st.integers(1, 5))):
        source = draw(st.sampled_from(["s1", "s2", "t1"]))
        readings: list[Reading] = []
        stamps: list[datetime] = []
        for _ in range(draw(st.integers(0, 6))):
            if stamps and draw(st.booleans()):  # a row of the same time object, maybe in UTC
                stamp = draw(st.sampled_from(stamps))
            else:
                stamp = T0 + timedelta(minutes=draw(st.integers(0, 12)))  # late rows too
                stamps.append(stamp)
            utc = draw(st.sampled_from([None, stamp.replace(tzinfo=UTC) + timedelta(hours=1)]))
            logger = draw(st.sampled_from(LOGGERS))
            counter = draw(st.integers(0, 2))
            for channel in draw(st.lists(st.integers(1, 4), min_size=1, max_size=4)):
                value = draw(st.one_of(st.none(), st.sampled_from(VALUES), st.floats(-3, 3)))
                name = draw(st.sampled_from(NAMES))
                reading = Reading(logger, channel, stamp, counter, 1, value, None, name, None, utc)
                readings.append(reading)
                if draw(st.booleans()) and draw(st.booleans()):
                    readings.append(reading)  # the same reading twice
        out.append((source, readings))
    return out


@st.composite
def calm_chunks(draw: st.DrawFn) -> list[tuple[str, list[Reading]]]:
    """Long runs of readings mostly on the good side of the limits, now and then one that
    crosses (the quiet readings of :mod:`sondalog.collect.alarms.ingest`), mostly in order,
    a channel sometimes renamed."""
    out = []
    minute = 0
    for _ in range(draw(st.integers(1, 4))):
        readings: list[Reading] = []
        for _ in range(draw(st.integers(0, 25))):
            minute += draw(st.sampled_from([1, 1, 1, 0, -2]))
            stamp = T0 + timedelta(minutes=minute)
            utc = draw(st.sampled_from([None, None, stamp.replace(tzinfo=UTC)]))
            logger = draw(st.sampled_from(LOGGERS[:2]))
            counter = draw(st.integers(0, 1))
            for channel in (1, 2, 3):
                calm = st.floats(0.55, 0.95)
                value = draw(st.one_of(calm, calm, calm, calm, st.sampled_from(VALUES)))
                name = draw(st.sampled_from(("T1", "T1", "T1", "T1", "T2", None)))
                readings.append(
                    Reading(logger, channel, stamp, counter, 1, value, None, name, None, utc)
                )
        out.append(("s1", readings))
    return out


def run(plan: AlarmPlan, feed: list[tuple[str, list[Reading]]], records: list[AlarmRecord]) -> None:
    """Both paths on the same chunks, each with a table of states saved after every chunk
    (the slow one whole by ``changed()``; the fast one by ``changes()``: whole rows where
    more than the progress changed, and each logger's row of its reading alarms' progress),
    compared as text (NaN equals NaN)."""
    slow, fast = Alarms(plan, records), Alarms(plan, records)
    slow_table = {r.alarm: _row(r) for r in records}
    fast_table = dict(slow_table)
    fast_progress: dict[str, bytes] = {}
    for source, readings in feed:
        expected = slow.readings(Sample.of(source, r) for r in readings)
        got = fast.ingest(source, readings)
        assert repr(got) == repr(expected)
        changed = slow.changed()
        slow_table |= {r.alarm: _row(r) for r in changed}
        changes = fast.changes()
        fast_table |= {row[0]: row for row in changes.states}
        for row in changes.counters:
            old = fast_table[row[0]]  # only the progress of a row the store has
            fast_table[row[0]] = old[:12] + row[12:16] + old[16:]
        assert [k for k, _ in changes.progress] == sorted({k for k, _ in changes.progress})
        fast_progress |= dict(changes.progress)
        written = {row[0] for row in changes.states + changes.counters}
        in_rows = {a for _, blob in changes.progress for a in unpack(blob)}
        assert written <= {r.alarm for r in changed} <= written | in_rows
        stored = _with_progress(fast_table, fast_progress)
        assert repr(sorted(stored.items())) == repr(sorted(slow_table.items()))
    stored = _with_progress(fast_table, fast_progress)
    assert repr(sorted(stored.values())) == repr(sorted(_row(r) for r in fast.export()))
    assert repr(sorted(fast.export(), key=_alarm)) == repr(sorted(slow.export(), key=_alarm))


def _with_progress(
    table: dict[str, tuple[object, ...]], progress: dict[str, bytes]
) -> dict[str, tuple[object, ...]]:
    """The rows of ``table`` as a store loads them: with the progress of the loggers' rows
    where it is not older (the rule of :func:`~sondalog.collect.alarms.progress.overlay`,
    the values exact)."""
    out = dict(table)
    for blob in progress.values():
        for alarm, (count, value, time, counter) in unpack(blob).items():
            row = out[alarm]
            last = row[14]
            if last is None or (time is not None and (time, counter) >= (last, row[15])):
                out[alarm] = (*row[:12], count, value, time, counter, *row[16:])
    return out


def _row(record: AlarmRecord) -> tuple[object, ...]:
    return tuple(getattr(record, f.name) for f in fields(AlarmRecord))


def _alarm(record: AlarmRecord) -> str:
    return record.alarm


@settings(max_examples=300, deadline=None)
@given(rules(), chunks(), chunks())
def test_ingest_answers_as_reading_on_random_rules_and_readings(
    plan: AlarmPlan,
    first: list[tuple[str, list[Reading]]],
    then: list[tuple[str, list[Reading]]],
) -> None:
    run(plan, first, [])
    # a restart: both start from the states the first run exported, then go on
    before = Alarms(plan)
    for source, readings in first:
        before.readings(Sample.of(source, r) for r in readings)
    run(plan, then, before.export())


def test_ingest_raises_and_clears_with_the_rows_own_times() -> None:
    """The benchmark's kind of config, fed as the collector stores it."""
    plan = plan_of(
        """
[[alarm]]
name = "hot"
kind = "threshold"
logger = "F*"
channel = "T1"
above = 2
clear = 1
for = 2
"""
    )
    alarms = Alarms(plan)
    values = [1.0, 2.5, 2.5, 1.0, 0.5]
    readings = [
        Reading("F01", 1, T0 + timedelta(minutes=i), 0, 1, v, None, "T1")
        for i, v in enumerate(values)
    ]
    out = alarms.ingest("s1", readings)
    assert [(t.what, t.time) for t in out] == [
        ("raised", (T0 + timedelta(minutes=2)).replace(tzinfo=UTC).timestamp()),
        ("cleared", (T0 + timedelta(minutes=4)).replace(tzinfo=UTC).timestamp()),
    ]
    assert alarms.ingest("s1", readings) == []  # the same rows again: ignored


def test_save_changes_writes_progress_in_the_loggers_row_and_whole_rows_on_a_change(
    tmp_path: Path,
) -> None:
    plan = plan_of(
        """
[[alarm]]
name = "flat"
kind = "stuck"
channel = 1
for = 3

[[alarm]]
name = "hot"
kind = "threshold"
channel = 1
above = 5
"""
    )
    alarms = Alarms(plan)

    def rows(first: int, values: list[float], logger: str = "F01") -> list[Reading]:
        return [
            Reading(logger, 1, T0 + timedelta(minutes=first + i), 0, 1, v)
            for i, v in enumerate(values)
        ]

    def stored(store: AlarmStore) -> dict[str, AlarmRecord]:
        return {r.alarm: r for r in store.load_states()}

    def progress_rows(store: AlarmStore) -> list[str]:
        return [r[0] for r in store.db.execute("SELECT logger FROM alarm_progress ORDER BY 1")]

    with AlarmStore(tmp_path / "collector.sqlite") as store:
        assert alarms.ingest("s1", rows(0, [1.0, 2.0])) == []
        changes = alarms.changes()
        assert len(changes.states) == 2 and changes.counters == []  # new alarms: whole
        assert [k for k, _ in changes.progress] == ["F01"]
        store.save_changes(changes)
        assert alarms.ingest("s1", rows(2, [2.0, 3.0])) == []
        changes = alarms.changes()
        assert changes.states == [] and changes.counters == []  # progress only: one row
        [(logger, blob)] = changes.progress
        assert logger == "F01" and len(blob) == 2 * 43
        store.save_changes(changes)
        assert stored(store) == {r.alarm: r for r in alarms.export()}
        columns = store.db.execute("SELECT max(last_time) FROM alarm_states").fetchone()[0]
        assert columns < max(r.last_time or 0 for r in alarms.export())  # not written
        out = alarms.ingest("s1", rows(4, [3.0, 3.0, 6.0]))
        assert [t.what for t in out] == ["raised", "cleared", "raised"]
        changes = alarms.changes()
        assert len(changes.states) == 2  # both changed state: whole rows
        store.save_changes(changes)
        alarms.ingest("s1", rows(0, [7.0], logger="F02"))  # a second logger
        changes = alarms.changes()
        assert [k for k, _ in changes.progress] == ["F02"]
        store.save_changes(changes)
        assert progress_rows(store) == ["F01", "F02"]
        assert stored(store) == {r.alarm: r for r in alarms.export()}
    with AlarmStore(tmp_path / "collector.sqlite") as store:  # a restart goes on from there
        again = Alarms(plan, store.load_states())
        assert again.ingest("s1", rows(6, [6.0])) == []  # an old row: ignored
        assert {r.alarm: r for r in again.export()} == {r.alarm: r for r in alarms.export()}
        out = again.ingest("s1", rows(8, [1.0, 1.0, 1.0]))
        assert repr(out) == repr(alarms.ingest("s1", rows(8, [1.0, 1.0, 1.0])))
        assert [t.what for t in out] == ["cleared", "raised"]  # hot; flat: three alike


def test_a_store_without_progress_rows_goes_on_from_its_columns(tmp_path: Path) -> None:
    """A store of the version before ``alarm_progress`` (the progress in the columns of
    ``alarm_states``), and columns written later than a logger's row: the newer wins."""
    plan = plan_of(
        """
[[alarm]]
name = "hot"
kind = "threshold"
channel = 1
above = 5
for = 3
"""
    )
    reading = [Reading("F01", 1, T0 + timedelta(minutes=i), 0, 1, 6.0) for i in range(3)]
    alarms = Alarms(plan)
    assert alarms.ingest("s1", reading[:2]) == []  # two of three
    path = tmp_path / "old.sqlite"
    with AlarmStore(path) as store:
        store.save_states(alarms.export())  # whole rows only, as the older version did
        assert store.db.execute("SELECT count(*) FROM alarm_progress").fetchone()[0] == 0
        again = Alarms(plan, store.load_states())
        assert [t.what for t in again.ingest("s1", reading[2:])] == ["raised"]
        store.save_changes(again.changes())
    alarms.ingest("s1", reading[2:])
    alarms.ingest("s1", [replace(reading[0], time=T0 + timedelta(minutes=9), value=1.0)])
    with AlarmStore(path) as store:
        store.save_states(alarms.export())  # newer columns than the logger's row
        assert store.load_states() == alarms.export()


@pytest.mark.timeout(600)  # long chunks: some 40 s on an idle machine
@settings(max_examples=200, deadline=None)
@given(rules(("threshold", "threshold", "threshold", "stuck")), calm_chunks(), calm_chunks())
def test_quiet_readings_answer_as_reading(
    plan: AlarmPlan,
    first: list[tuple[str, list[Reading]]],
    then: list[tuple[str, list[Reading]]],
) -> None:
    """Threshold rules on long calm runs: the quiet readings only move the newest reading,
    settled into the alarms before a crossing and at the end of a chunk."""
    run(plan, first, [])
    before = Alarms(plan)
    for source, readings in first:
        before.readings(Sample.of(source, r) for r in readings)
    run(plan, then, before.export())


def run_stored(
    plan: AlarmPlan, feed: list[tuple[str, list[Reading]]], then: list[tuple[str, list[Reading]]]
) -> None:
    """Both paths saving into a real store of their own after every chunk (the slow one
    whole rows, ``save_states``; the fast one ``save_changes``: progress only, equal progress
    grouped into one statement), then both restarted from their stores: the stores hold the
    same rows after every chunk (NaN is stored as NULL by both alike), and the transitions
    are the same before and after the restart."""
    with tempfile.TemporaryDirectory() as tmp:
        slow_path, fast_path = Path(tmp) / "slow.sqlite", Path(tmp) / "fast.sqlite"
        for part in (feed, then):
            with AlarmStore(slow_path) as slow_store, AlarmStore(fast_path) as fast_store:
                slow = Alarms(plan, slow_store.load_states())
                fast = Alarms(plan, fast_store.load_states())
                for source, readings in part:
                    expected = slow.readings(Sample.of(source, r) for r in readings)
                    assert repr(fast.ingest(source, readings)) == repr(expected)
                    slow_store.save_states(slow.changed())
                    with fast_store.transaction():
                        fast_store.save_changes(fast.changes())
                    got = fast_store.load_states()
                    assert repr(got) == repr(slow_store.load_states())
                    assert got == sorted(map(_as_stored, fast.export()), key=_alarm)  # -0.0 is 0


def _as_stored(record: AlarmRecord) -> AlarmRecord:
    """A record as SQLite gives it back: NaN is NULL (and -0.0 is 0)."""
    nan = [f.name for f in fields(AlarmRecord) if _is_nan(getattr(record, f.name))]
    return replace(record, **dict.fromkeys(nan))


def _is_nan(value: object) -> bool:
    return isinstance(value, float) and math.isnan(value)


@settings(max_examples=80, deadline=None)
@given(rules(("threshold", "threshold", "stuck", "step")), calm_chunks(), calm_chunks())
def test_the_stored_progress_is_the_slow_paths_across_a_restart(
    plan: AlarmPlan,
    first: list[tuple[str, list[Reading]]],
    then: list[tuple[str, list[Reading]]],
) -> None:
    run_stored(plan, first, then)


@settings(max_examples=80, deadline=None)
@given(rules(), chunks(), chunks())
def test_the_stored_progress_is_the_slow_paths_on_random_readings(
    plan: AlarmPlan,
    first: list[tuple[str, list[Reading]]],
    then: list[tuple[str, list[Reading]]],
) -> None:
    run_stored(plan, first, then)
