"""The series path (issue 24) against the event-by-event path on random configurations.

Each example builds one logger twice in the same simulated world: once as users run it (the
compiled measurements and :mod:`sondalog.ala1.series`), once on the reference path
(``Measurer.fast = False``: instant by instant, every channel interpreted). Random channel
types (analog, switched analog, DS18B20, supply, pulses, events, 2-D, GSM), periods, starts,
switches with switch-on delays (some as long as the period), manual outputs, averaging,
record conditions, 1-D, 2-D, second and missing tables, calibrations of the device, the
input and the channel, a message on a threshold and a message of the record; on-demand
reads, manual outputs, the clock set and a kill (the logger started again from its state
file, issue 24 sixth round) between random clock steps; every signal model the
simulation reads as a column (shifted to the start as a site file's, clamped). The two must
agree on every byte: the record memory, every answer, and every sending of the message
outbox; the record large, or small enough to wrap (cyclic) or fill up (linear), its oldest
and next rows (the erase and read pointers) as RAM and the store have them, and its
download by XMODEM. (Checked by breaking the series path on purpose: ignoring the switch-on
delays of channels not sampled at an instant, taking every first pulse window as a whole
period, ignoring the delays of other periods when grouping instants by the outputs on, or
moving the samples condition of a run of one text by a sample, fails it; and the stretch's
rows at once: not setting the wrapped flag, or filling a linear record past its size.)
"""

from __future__ import annotations

import tempfile
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest
from ala1_module import T0, Module
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_special_xmodem import pump

from sondalog.ala1 import Engine, Identity, Version, series
from sondalog.ala1.hardware import rom_code
from sondalog.ala1.measure import Measurer
from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware, Thermometer
from sondalog.backends.sim.signals import Clamp, RandomWalk, Schedule, constant, ramp, shifted, sine
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.protocol.tables import build_files
from sondalog.protocol.xmodem import XmodemReceiver

ROM_A, ROM_B = rom_code(0x1234), rom_code(0x5678)
TABLES = {
    "t1": b"0 -5\n0.5 40\n1.2 95\n2.5 310\n",
    "t2": b"0\n0 0\n2.5 2500\n20\n0 10\n2.5 2520\n",
    "big": b"-100 -1000\n0 0\n100 1000\n2000 20000\n",
}
INPUTS = {  # what a channel reads: the parts of its configuration
    "analog": "type 3|device 1|address 16",
    "powered": "type 3|device 1|address 17",  # powered by output 2 in the world
    "external": "type 3|device 1|address 33",
    "walk": "type 3|device 1|address 19",  # powered by output 3 in the world
    "schedule": "type 3|device 1|address 20",  # powered by output 1
    "ds_rom": f"type 3|device 3|address x {ROM_A:X}",
    "ds_only": "type 3|device 3|address 0",  # alone on its pin while output 3 is off
    "supply": "type 1|device 1|address 21",
    "timer": "type 2|device 4|address 0",
    "pin": "type 2|device 1|address 18",
    "events": "type 6|device 4|address 0",
    "two_d": f"type 9|device all 1,3|address all x 10,{ROM_A:X}",
    "signal": "type 12",
    "credit": "type 11",
    "none": "type 3|device 0",
}


def world() -> SimHardware:
    """Every signal model the series path reads as a column: shifted to the start as a site
    file's are, clamped by a lambda or by the site's Clamp, and a schedule read value by
    value."""
    clamp = lambda v: min(2.4, max(0.0, v))  # noqa: E731
    return SimHardware(
        supply=shifted(sine(12.4, 0.3, 7200.0, 0.0, 0.0), T0),
        supply_power=1,
        analog=[
            Analog(16, RandomWalk(1.0, 0.05, 30.0, 3, T0, clamp)),
            Analog(17, sine(1.2, 1.1, 3000.0, 0.0, T0), power=2),
            Analog(19, shifted(RandomWalk(0.5, 0.2, 45.0, 4, 0.0, Clamp(0.0, 1.5)), T0), 3),
            Analog(20, Schedule([(0.0, 0.3), (900.0, 1.9), (2000.0, 0.0)], T0, True, True), 1),
        ],
        pulses=[
            PulseSource(True, 0, burst_rate=0.004, burst=3, seed=5, origin=T0),
            PulseSource(False, 18, rate=0.3, origin=T0),
        ],
        thermometers=[
            Thermometer(4, ROM_A, sine(18.0, 6.0, 5000.0, 0.0, T0)),
            Thermometer(4, ROM_B, constant(4.5), power=3),
        ],
        gsm={
            "signal": shifted(constant(21.0), T0),
            "credit": shifted(ramp(300.0, -0.05, 0.0, Clamp(290.0, 299.0)), T0),
        },
    )


channel = st.fixed_dictionaries(
    {
        "input": st.sampled_from([*sorted(INPUTS), "pin", "powered", "ds_only"]),
        "period": st.sampled_from([10, 15, 20, 30, 60]),
        "start": st.one_of(  # also later; on the minute (in step with other channels)
            st.integers(0, 59), st.integers(600, 3600), st.just(0), st.just(600)
        ),
        "switch": st.sampled_from([0, 0, 1, 2, 3]),
        "advance": st.sampled_from([0, 1, 3, 7, 40]),  # 40: longer than some periods
        "second_switch": st.sampled_from([0, 2, 3]),
        "average": st.sampled_from([0, 0, 1, 3, 4]),
        "change": st.sampled_from(["0", "-1", "0.01", "0.5", "2"]),
        "samples": st.sampled_from([0, 0, 3]),
        "table1": st.sampled_from(["", "", "t1", "t2", "big", "zz"]),
        "table2": st.sampled_from(["", "", "big", "t2"]),
        "format": st.sampled_from(["0.0", "0.1", "0.2", "5.3"]),
        "mult": st.sampled_from(["1", "1", "-2.5", "1000"]),
        "add": st.sampled_from(["0", "0", "0.25"]),
        "cal2": st.sampled_from([("1", "0"), ("1", "0"), ("2", "-0.5")]),
    }
)
step = st.one_of(
    st.tuples(st.just("advance"), st.integers(1, 3000)),
    st.tuples(st.just("advance"), st.integers(1, 3000)),
    st.tuples(st.just("read"), st.integers(1, 6)),
    st.tuples(st.just("output"), st.sampled_from(["0", "1", "NO"])),
    st.tuples(st.just("date"), st.integers(-900, 900)),  # the clock set (§6.2)
    st.tuples(st.just("reopen"), st.just(0)),  # killed, started again from its state file
)
setup = st.fixed_dictionaries(
    {
        "channels": st.lists(channel, min_size=1, max_size=6),
        "steps": st.lists(step, min_size=1, max_size=12),
        "watch": st.integers(1, 6),
        "function": st.sampled_from(["up", "down", "no"]),
        "threshold": st.sampled_from(["0", "0.5", "1", "18", "100"]),
        "hysteresis": st.sampled_from(["0", "0.2", "3"]),
        "of_record": st.booleans(),
        # the device calibrations (§6.4.4): the ADC's and the timer's
        "device_cal": st.sampled_from([("1", "0"), ("1", "0"), ("0.5", "0.01")]),
        # the DS18B20's (its factory value turns a reading into degrees Celsius)
        "ds_cal": st.sampled_from([None, ("3200", "-1.5")]),
        # the record: large, or small enough to wrap (cyclic) or fill (linear) with the
        # rows of a stretch, over a page (64 rows) or within one
        "record": st.sampled_from(
            [(983040, "CYCLIC")] * 3 + [(1024, "CYCLIC"), (8192, "CYCLIC"), (8192, "LINEAR")]
        ),
    }
)


def configure(m: Module, case: dict[str, Any]) -> None:
    channels = case["channels"]
    n = len(channels)
    m.ok(f"write date 20070101000000 write channel max number {n}")
    size, kind = case.get("record", (983040, "CYCLIC"))
    m.ok(f"write file record size {size} write file list size 256 write file data size 51200")
    m.ok(f"write record type {kind}")
    listing, data = build_files(TABLES)
    m.engine.state.write_file("list", listing)
    m.engine.state.write_file("data", data)
    m.ok("write device 3 type ds18b20 write device 3 address 4 write device 4 type msp430ta")
    mult, add = case.get("device_cal", ("1", "0"))
    for device in (1, 4):
        m.ok(f"write device {device} cal mult {mult} write device {device} cal add {add}")
    if case.get("ds_cal") is not None:
        m.ok("write device 3 cal mult {} write device 3 cal add {}".format(*case["ds_cal"]))
    m.ok("write output 2 device 1 write output 2 address 6")
    m.ok("write output 3 device 1 write output 3 address 5")
    for ch, c in enumerate(channels, 1):
        parts = INPUTS[c["input"]].split("|")
        parts += [
            f"switch output all {c['switch']},{c['second_switch']}",
            f"switch advance all {c['advance']},{c['advance'] // 2}",
            f"format {c['format']}",
            f"cal mult value {c['mult']}",
            f"cal add value {c.get('add', '0')}",
            f"cal2 mult {c.get('cal2', ('1', '0'))[0]}",
            f"cal2 add {c.get('cal2', ('1', '0'))[1]}",
            f"average samples {c['average']}",
            f"record change {c['change']}",
            f"record samples {c['samples']}",
            f"convert 1 file name/{c['table1']}/",
            f"convert 2 file name/{c['table2']}/",
            f"sampling period 00{c['period'] // 60:02d}{c['period'] % 60:02d}",
            f"sampling start 20070101{c['start'] // 3600:02d}{c['start'] // 60 % 60:02d}"
            f"{c['start'] % 60:02d}",
        ]
        for part in parts:
            m.ok(f"write channel {ch} {part}")
    m.ok("write com device wavecom41 write address 1 type sms 1 value/+420700000001/")
    m.ok("write command 1 value|read channel value|")
    m.ok("write command 2 value|read record 2 from end|")
    watch = min(case["watch"], n)
    m.ok(f"write message 1 address 1 write message 1 of channel function {case['function']}")
    m.ok(f"write message 1 of channel number {watch}")
    m.ok(f"write message 1 of channel value {case['threshold']}")
    m.ok(f"write message 1 of channel hysteresis {case['hysteresis']}")
    of_record = "yes" if case["of_record"] else "no"
    m.ok(f"write message 2 address 1 command 2 write message 2 of record function {of_record}")
    m.ok("write com close")


def run(case: dict[str, Any], fast: bool, monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """Everything the logger says and keeps: answers, sendings, the record, final reads."""
    monkeypatch.setattr(Measurer, "fast", fast)
    with tempfile.TemporaryDirectory() as directory:
        return _run(case, Path(directory) / "ala1.sqlite")


def _unsynced(store: SqliteNvStore) -> SqliteNvStore:
    """No fsync of each command's commit (a kill of the process loses nothing written)."""
    store.database.conn.execute("PRAGMA synchronous=OFF")
    return store


def _run(case: dict[str, Any], path: Path) -> list[object]:
    hardware = world()
    m = Module(db=path, hardware=hardware)
    _unsynced(m.store)
    configure(m, case)
    seen: list[object] = []

    def sendings() -> None:
        while (outgoing := m.engine.outbox.take()) is not None:
            seen.append((m.now, outgoing.message, outgoing.body, outgoing.destinations))
            m.engine.outbox.done(outgoing.ident, True)

    for kind, arg in case["steps"]:
        if kind == "advance":
            seen.append(m.advance(float(arg)))
        elif kind == "read":
            seen.append(m.ask(f"read channel {min(int(arg), len(case['channels']))} value"))
        elif kind == "output":
            seen.append(m.ask(f"write output 3 value {arg} write com close"))
        elif kind == "reopen":  # (a kill: the store writes at once, nothing waits)
            # the process made again: its simulated outputs off as at power-up (a new engine
            # takes them as off and tells the hardware only of changes; see decisions.md)
            hardware.outputs.clear()
            killed = m.store
            m.store = _unsynced(SqliteNvStore(path))
            m.engine = Engine(Identity(Version.V2_10), m.store, m.now, hardware)
            m.line = m.engine.open_line()
            killed.close()
        else:
            moment = m.engine.state.module_time(m.now) + timedelta(seconds=int(arg))
            seen.append(m.ask(f"write date {moment:%Y%m%d%H%M%S} write com close"))
        sendings()
    seen.append(m.advance(3600.0))
    sendings()
    seen.append(m.ask("read channel sample"))
    seen.append(m.ask("read channel record value"))
    seen.append(m.ask("read record status"))
    seen.append(m.ask("read record 3 from end"))
    record = m.engine.state.record
    # the oldest row kept and the next (the erase and read pointers), as RAM and the store
    # have them, and the record downloaded by XMODEM (§6.16.3)
    seen.append((record.next_seq - len(record), record.next_seq, record.wrapped, record.refused))
    seen.append(m.store.load_record())
    got = XmodemReceiver()
    seen.append((pump(m, got, "read special file record xmodem"), got.data))
    seen.append(record.rows())
    seen.append(dict(m.engine.state.outputs.applied))
    m.store.close()
    return seen


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(case=setup)
def test_the_series_path_is_byte_identical_on_random_configurations(
    case: dict[str, Any],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert run(case, True, monkeypatch) == run(case, False, monkeypatch)


def test_the_random_worlds_take_the_series_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """The comparison above is worth something only if the series path runs: a switched
    configuration of the same kind takes it for most instants."""
    taken: list[bool] = []
    original = series.run_series

    def spy(*args: object) -> bool:
        result = original(*args)  # type: ignore[arg-type]
        taken.append(result)
        return result

    monkeypatch.setattr("sondalog.ala1.sampling.run_series", spy)
    channels = [
        dict(c, period=30, start=0, switch=2, advance=3, second_switch=3)
        for c in (
            {"input": name, "average": 3, "change": "0.01", "samples": 0, "table1": "t1"}
            | {"table2": "", "format": "0.2", "mult": "1"}
            for name in ("powered", "ds_only", "two_d", "timer", "credit")
        )
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 3000), ("read", 1), ("advance", 3000)],
        "watch": 1,
        "function": "up",
        "threshold": "1",
        "hysteresis": "0.2",
        "of_record": True,
    }
    assert run(case, True, monkeypatch) == run(case, False, monkeypatch)
    assert taken.count(True) >= 2, taken


def test_stretches_longer_than_a_chunk(monkeypatch: pytest.MonkeyPatch) -> None:
    """One advance of many chunks (``series.CHUNK`` instants each): the stretches join as
    the event-by-event path runs on, with switch-on delays running across their ends."""
    monkeypatch.setattr(series, "CHUNK", 97)
    base = {"average": 3, "change": "0.01", "samples": 3, "table1": "", "table2": "big"}
    base |= {"format": "0.2", "mult": "1", "second_switch": 0}
    channels = [
        base | {"input": "powered", "period": 10, "start": 0, "switch": 2, "advance": 7},
        base | {"input": "ds_only", "period": 15, "start": 3, "switch": 3, "advance": 12},
        base | {"input": "pin", "period": 20, "start": 5, "switch": 0, "advance": 0},
        base | {"input": "events", "period": 10, "start": 0, "switch": 0, "advance": 0},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 20_000), ("read", 2), ("advance", 7), ("advance", 15_000)],
        "watch": 1,
        "function": "down",
        "threshold": "1",
        "hysteresis": "0.2",
        "of_record": True,
    }
    assert run(case, True, monkeypatch) == run(case, False, monkeypatch)


def test_a_stretch_ends_before_channels_that_start_later(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two switched channels whose delays overlap each other's samples leave no instant
    without a delay running once both sample; the second starts half an hour later, so a
    stretch ends before it starts and takes none of its instants."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "0.2", "mult": "1", "second_switch": 0, "period": 60, "advance": 40}
    channels = [
        base | {"input": "powered", "start": 0, "switch": 2},
        base | {"input": "ds_only", "start": 1830, "switch": 3},
        base | {"input": "analog", "start": 1800, "period": 10, "switch": 0, "advance": 0},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 7200)],
        "watch": 1,
        "function": "no",
        "threshold": "1",
        "hysteresis": "0",
        "of_record": False,
    }
    assert run(case, True, monkeypatch) == run(case, False, monkeypatch)


def test_a_channel_reads_what_the_delays_of_other_periods_power(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Channels of different periods: an input powered by output 3 is read by a channel that
    switches nothing, at instants inside the switch-on delay of another channel switching
    output 3 (a value) and outside it (none); the series path groups the instants by the
    outputs on as the event-by-event path switches them."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "0.3", "mult": "1", "second_switch": 0}
    channels = [
        base | {"input": "analog", "period": 20, "start": 0, "switch": 3, "advance": 12},
        base | {"input": "walk", "period": 15, "start": 0, "switch": 0, "advance": 0},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 3600)],
        "watch": 2,
        "function": "no",
        "threshold": "1",
        "hysteresis": "0",
        "of_record": False,
    }
    fast, slow = run(case, True, monkeypatch), run(case, False, monkeypatch)
    assert fast == slow
    rows: list[str] = slow[-2]  # type: ignore[assignment]
    fields = [row.split(",")[3] for row in rows]
    assert "" in fields and any(fields), fields  # read inside and outside the delays


def test_a_delay_running_when_the_clock_is_set_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """The clock set back 15 minutes while a switch-on delay runs: the sensor stays powered
    until its channel's next sample, a quarter of an hour later, and another channel reads
    the input it powers meanwhile (found by the property test: the series path had switched
    it off)."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "0.1", "mult": "1", "second_switch": 0, "period": 10}
    channels = [
        base | {"input": "supply", "start": 0, "switch": 0, "advance": 0},  # powered by 1
        base | {"input": "analog", "start": 14, "switch": 1, "advance": 7},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 400), ("date", -900), ("advance", 1440)],
        "watch": 1,
        "function": "no",
        "threshold": "1",
        "hysteresis": "0",
        "of_record": False,
    }
    fast, slow = run(case, True, monkeypatch), run(case, False, monkeypatch)
    assert fast == slow
    rows: list[str] = slow[-2]  # type: ignore[assignment]
    assert any(row.startswith("20070101000000") and row.split(",")[2] for row in rows), rows


def test_calibrated_pulse_channels_without_pulses(monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows without a pulse (a rain gauge on a dry day) read 0 * mult + add on the timer
    and 0 on a pin, through the device's calibration, on both paths; the DS18B20's own
    calibration too."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "5.3", "mult": "1", "second_switch": 0, "switch": 0, "advance": 0}
    channels = [
        base | {"input": "timer", "period": 10, "start": 0},
        base | {"input": "pin", "period": 15, "start": 3},
        base | {"input": "events", "period": 10, "start": 0, "average": 2},
        base | {"input": "ds_rom", "period": 20, "start": 0},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 40)] * 30 + [("read", 1), ("advance", 3000)],  # (dry stretches)
        "watch": 1,
        "function": "up",
        "threshold": "1",
        "hysteresis": "0.2",
        "of_record": False,
        "device_cal": ("0.5", "0.01"),
        "ds_cal": ("3200", "-1.5"),
    }
    assert run(case, True, monkeypatch) == run(case, False, monkeypatch)


def test_instants_of_several_periods_that_only_look_like_a_progression(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Found by the property test: the instants of five cohorts (periods of 15, 20 and 30 s,
    starts 0, 5, 37 and 7 s into the minute) start 5 s apart and end as far apart as 5 s
    steps would, without being every 5 s; the series path took them for a progression and
    powered output 2 at the wrong instants (a channel reading the input it powers got no
    value where it had one, and one where it had none)."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "0.0", "mult": "1", "second_switch": 0, "switch": 0, "advance": 0}
    channels = [
        base | {"input": "analog", "period": 20, "start": 0},
        base | {"input": "analog", "period": 20, "start": 0, "switch": 2},
        base | {"input": "analog", "period": 20, "start": 45},
        base | {"input": "powered", "period": 15, "start": 0},
        base | {"input": "analog", "period": 15, "start": 1117},
        base | {"input": "analog", "period": 30, "start": 7},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 75), ("advance", 206), ("advance", 207), ("advance", 582)],
        "watch": 1,
        "function": "up",
        "threshold": "0",
        "hysteresis": "0",
        "of_record": False,
    }
    fast, slow = run(case, True, monkeypatch), run(case, False, monkeypatch)
    assert fast == slow
    rows: list[str] = slow[-2]  # type: ignore[assignment]
    fields = [row.split(",")[5] for row in rows if row[12:14] == "00"]  # channel 4's
    assert "" in fields and any(fields), fields  # powered at some instants, not at others


@pytest.mark.parametrize("record", [(1024, "CYCLIC"), (8192, "CYCLIC"), (8192, "LINEAR")])
def test_stretches_that_wrap_or_fill_the_record(
    monkeypatch: pytest.MonkeyPatch, record: tuple[int, str]
) -> None:
    """Stretches of rows at once (``RecordMemory.append_many``) wrap a small cyclic record
    (within a page, over pages) and fill a linear one as rows one by one do: the same rows
    kept, flags, pointers, store and download."""
    base = {"average": 0, "change": "0", "samples": 0, "table1": "", "table2": ""}
    base |= {"format": "0.3", "mult": "1", "second_switch": 0, "switch": 0, "advance": 0}
    channels = [
        base | {"input": "analog", "period": 10, "start": 0},
        base | {"input": "walk", "period": 20, "start": 5, "average": 3, "change": "0.01"},
        base | {"input": "powered", "period": 30, "start": 0, "switch": 2, "advance": 7},
    ]
    case = {
        "channels": channels,
        "steps": [("advance", 600), ("advance", 3000), ("read", 1), ("advance", 2000)],
        "watch": 1,
        "function": "no",
        "threshold": "1",
        "hysteresis": "0",
        "of_record": False,
        "record": record,
    }
    fast, slow = run(case, True, monkeypatch), run(case, False, monkeypatch)
    assert fast == slow
    status = slow[-7]
    assert isinstance(status, bytes) and b"FULL" in status, status
