"""Scheduled sampling's fast path (issue 11: a year in 5 s) writes the record byte for byte
as the interpreted path does: the same seeded world, a week of 12 channels sampled every
minute with averaging and record conditions, stored by the SQLite memory."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from ala1_module import T0, Module

from sondalog.ala1.measure import Measurer
from sondalog.ala1.sampling import ChannelRun, RowSink, Sampler
from sondalog.ala1.series import run_series
from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware
from sondalog.backends.sim.signals import RandomWalk, sine
from sondalog.protocol.tables import build_files

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_sampling.py"
ADDRESSES = (16, 17, 18, 19, 20, 24)
DAYS = 7


def world() -> SimHardware:
    return SimHardware(
        supply=sine(12.4, 0.3, 86400.0, 0.0, T0),
        analog=[
            Analog(a, sine(1.0, 0.8, 86400.0 / (i + 1), 0.0, T0))
            if i % 2
            else Analog(a, RandomWalk(1.0, 0.01, 60.0, i, T0, lambda v: min(2.4, max(0.0, v))))
            for i, a in enumerate(ADDRESSES)
        ],
        pulses=[PulseSource(True, 0, rate=0.5, origin=T0)],
    )


def logged_week(
    db: Path, fast: bool, monkeypatch: pytest.MonkeyPatch, switched: bool = True
) -> list[str]:
    monkeypatch.setattr(Measurer, "fast", fast)
    m = Module(db=db, hardware=world())
    m.ok("write date 20070101000000 write channel max number 12")
    m.ok("write file record size 983040 write file list size 256 write file data size 51200")
    listing, data = build_files({"sq": b"0 0\n1000 2000\n2500 3000\n"})
    m.engine.state.write_file("list", listing)
    m.engine.state.write_file("data", data)
    for ch in range(1, 13):
        average = 10 if ch % 3 else 0
        m.ok(f"write channel {ch} type 3 write channel {ch} address {ADDRESSES[ch % 6]}")
        m.ok(f"write channel {ch} switch output 0 write channel {ch} format 0.{ch % 4}")
        m.ok(f"write channel {ch} sampling period 000100")
        m.ok(f"write channel {ch} sampling start 20070101000000")
        m.ok(f"write channel {ch} average samples {average} write channel {ch} record change 0.02")
    m.ok("write channel 2 cal mult value 3.5 write channel 2 cal add value -0.25")
    m.ok("write channel 3 cal2 mult 1000 write channel 3 convert file name/sq/")  # a table
    m.ok("write channel 4 type 2 write channel 4 device 1 write channel 4 address 0")  # pulses
    if switched:
        m.ok("write channel 5 switch output 2 write channel 5 switch advance 2")
    m.ok("write channel 6 type 1 write channel 6 address 0")  # the supply
    m.ok("write output 2 device 1 write output 2 address 8")
    for hour in range(1, DAYS * 24 + 1):
        m.advance(T0 + hour * 3600 - m.now)
    rows = m.engine.state.record.rows()
    m.store.close()
    return rows


def test_a_week_fast_is_byte_identical_to_the_interpreted_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    slow = logged_week(tmp_path / "slow.sqlite", False, monkeypatch)
    fast = logged_week(tmp_path / "fast.sqlite", True, monkeypatch)
    assert len(slow) > DAYS * 1440 // 2  # channels with no averaging write most minutes
    assert fast == slow
    columns = [row.split(",") for row in fast[-5:]]
    assert all(len(c) == 14 for c in columns), columns  # stamp, type, 12 fields


def test_a_series_of_instants_is_sampled_as_instant_by_instant(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Channels that sample together and switch nothing run as a series of instants
    (``Sampler._series``, or channel by channel in ``series.run_series``); event by event
    they log the same week."""
    series = logged_week(tmp_path / "series.sqlite", True, monkeypatch, switched=False)

    def one_instant(
        sampler: Sampler, t: int, due: list[ChannelRun], target: float, offset: float, sink: RowSink
    ) -> None:
        sampler._sample(t, due, offset, sink)

    monkeypatch.setattr(Sampler, "_series", one_instant)
    monkeypatch.setattr("sondalog.ala1.sampling.run_series", lambda *args: False)
    events = logged_week(tmp_path / "events.sqlite", True, monkeypatch, switched=False)
    assert len(events) > DAYS * 1440 // 2
    assert series == events


@pytest.mark.parametrize("mixed", [False, True])
def test_the_realistic_benchmark_logger_is_sampled_in_series_as_event_by_event(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, mixed: bool
) -> None:
    """bench_sampling's realistic logger (issue 24: the site file's seven inputs, switched,
    1-Wire, pulses, GSM, tables, averaging, a message on a threshold), three days: the
    series path takes the instants, and the record, the samples and the SMS sent are those
    of the interpreted event-by-event path; also with its channels at 1, 5 and 10 minutes
    (``--periods``: switched channels sampled at some of the instants only)."""
    spec = importlib.util.spec_from_file_location("bench_sampling", BENCH)
    assert spec is not None and spec.loader is not None
    bench_sampling = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench_sampling)
    taken: list[bool] = []
    original = run_series

    def spy(*args: object) -> bool:
        result = original(*args)  # type: ignore[arg-type]
        taken.append(result)
        return result

    monkeypatch.setattr("sondalog.ala1.sampling.run_series", spy)
    monkeypatch.setattr(bench_sampling, "DAYS", 3)
    got = []
    for fast in (True, False):
        monkeypatch.setattr(Measurer, "fast", fast)
        periods = bench_sampling.MIXED_PERIODS if mixed else None
        db = tmp_path / f"{fast}.sqlite"
        _, _, engine, written, sent = bench_sampling.realistic_year(db, periods)
        line = engine.open_line()
        samples = bench_sampling.ask(engine, line, "read channel sample", T0 + 3 * 86400)
        got.append((engine.state.record.rows(), written, sent, samples))
    assert got[0] == got[1]
    assert got[0][1] > (500 if mixed else 1000) and samples.count(b",") == 11
    assert taken.count(True) >= 3  # a stretch per simulated day at least
