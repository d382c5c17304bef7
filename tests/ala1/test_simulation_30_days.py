"""30 days of a 4-channel logger against an independent computation of its record.

The reference below recomputes, from the same signals, what the module must log: sample
times, 12-bit A/D readings, calibration, averaging and the record conditions of §6.5.15 and
§6.5.16. It shares no code with the module's scheduler.
"""

from __future__ import annotations

import math
from collections import defaultdict
from datetime import datetime, timedelta
from decimal import ROUND_HALF_UP, Decimal

from ala1_module import T0, Module

from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware
from sondalog.backends.sim.signals import RandomWalk, Schedule, sine

START = datetime(2007, 3, 1, 0, 0, 0)  # module time at T0 + 1
DAYS = 30


def fmt(value: float, decimals: int) -> str:
    q = Decimal(repr(value)).quantize(Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_UP)
    return f"{abs(q) if q == 0 else q:.{decimals}f}"


def adc(volts: float) -> float:
    return min(4095, max(0, round(volts / 2.5 * 4095))) / 4095 * 2.5


def test_thirty_days_of_logging_match_the_reference() -> None:
    s1 = sine(1.2, 0.7, 86400.0, 0.0, T0)
    s2 = RandomWalk(1.0, 0.02, 300.0, 42, T0, lambda v: min(2.4, max(0.1, v)))
    s3 = Schedule([(0.0, 12.6), (5 * 86400.0, 12.2), (17 * 86400.0, 11.7)], T0, False, False)
    hw = SimHardware(
        supply=s3,
        analog=[Analog(16, s1), Analog(17, s2)],
        pulses=[PulseSource(True, 0, rate=0.5, origin=T0)],
    )
    m = Module(hardware=hw)
    m.ok("write date 20070228235959")
    m.ok("write channel max number 4")
    m.ok("write device 2 type msp430ta")
    for ch, line in (
        (1, "type 3|address 16|format 0.3|average samples 6|record change 0"),
        (2, "type 3|address 17|format 0.2|record change 0.05|record samples 12"),
        (3, "type 1|format 0.1|record change 0.1"),
        (4, "type 2|device 2|format 0.0|record change 0"),
    ):
        for part in line.split("|"):
            m.ok(f"write channel {ch} {part}")
        m.ok(f"write channel {ch} switch output 0")
    m.ok("write output 1 value 1")  # supply divider on for channel 3
    m.ok("write channel sampling period 001000 000500 010000 001500")
    m.ok("write channel sampling start 20070301000000 20070301000000 20070301000000 20070301000000")
    m.advance(DAYS * 86400 + 1)
    answer = m.ask("read record 1000000 from start").decode()
    assert answer.endswith("OK\r\n")
    got = answer.split("\r\n")[:-2]

    # -- the reference ---------------------------------------------------------------------
    end = DAYS * 86400
    rows: dict[int, dict[int, str]] = defaultdict(dict)

    def host(t: int) -> float:
        return T0 + 1 + t

    # channel 1: 10-minute samples averaged by 6, every average written
    acc: list[float] = []
    for t in range(0, end + 1, 600):
        acc.append(adc(s1(host(t))))
        if len(acc) == 6:
            rows[t][1] = fmt(sum(acc) / 6, 3)
            acc = []
    # channel 2: change >= 0.05 or every 12th sample since the last row
    last: str | None = None
    since = 0
    for t in range(0, end + 1, 300):
        text = fmt(adc(s2(host(t))), 2)
        since += 1
        if last is None or abs(Decimal(text) - Decimal(last)) >= Decimal("0.05") or since >= 12:
            rows[t][2] = text
            last, since = text, 0
    # channel 3: the supply divider 1:11, change >= 0.1
    last = None
    for t in range(0, end + 1, 3600):
        raw = min(4095, round(s3(host(t)) / 11 / 2.5 * 4095)) / 4095
        text = fmt(raw * 2.5 * 11, 1)
        if last is None or abs(Decimal(text) - Decimal(last)) >= Decimal("0.1"):
            rows[t][3] = text
            last = text
    # channel 4: pulses per 15 minutes at 0.5 Hz
    for t in range(0, end + 1, 900):
        rows[t][4] = fmt(float(math.floor((t + 1) * 0.5) - math.floor((t + 1 - 900) * 0.5)), 0)

    expected = []
    counters: dict[str, int] = defaultdict(int)
    for t in sorted(rows):
        stamp = (START + timedelta(seconds=t)).strftime("%Y%m%d%H%M%S")
        fields = ",".join(rows[t].get(ch, "") for ch in range(1, 5))
        expected.append(f"{stamp}.{counters[stamp]},1,{fields}")
        counters[stamp] += 1

    assert len(got) == len(expected) > 4000, (len(got), len(expected))
    mismatches = [(g, e) for g, e in zip(got, expected, strict=True) if g != e]
    assert not mismatches, mismatches[:5]
