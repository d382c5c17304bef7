"""Scheduled sampling and the switches (§6.5.13-§6.5.16, §6.7, §6.9; spec notes §7).

Times here are *module* seconds (the module clock as seconds since 1970); the hardware is
asked at the matching host time. A channel with period P and start S samples at S + k*P; a
start in the past moves forward by whole periods. Channels sampled in the same second share
one row of type 1. A switched sensor is powered ``advance`` seconds before its sample and
switched off after it, unless an on-demand read holds it (``command channel switch hold``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal

from sondalog.ala1.hardware import Hardware
from sondalog.ala1.measure import ChannelConfig, Measurer, format_value
from sondalog.ala1.moduleclock import to_seconds
from sondalog.ala1.tokens import parse_stamp

_ZERO = Decimal(0)
_NEVER = Decimal(-1)


@dataclass(slots=True)
class ChannelRun:
    """Sampling state of one channel (RAM, like the module's)."""

    cfg: ChannelConfig
    next_t: int | None = None
    last_t: int | None = None
    avg_sum: float = 0.0
    avg_n: int = 0
    since_write: int = 0
    recorded: str | None = None  # last value written to the record (formatted)
    event_active: bool = False  # type 6: the last sample met the condition
    sample: float | None = None  # last scheduled sample (unformatted)
    sampled: bool = False
    #: ``Measurer.compiled(cfg)``, made at the first sample after a configuration.
    measure: Callable[[float, float], float | None] | None = None

    def schedule(self, now: int) -> None:
        cfg = self.cfg
        if cfg.period <= 0:
            self.next_t = None
            return
        start = _stamp_seconds(cfg.start)
        if now <= start:
            self.next_t = start
        else:
            self.next_t = start + math.ceil((now - start) / cfg.period) * cfg.period


def _stamp_seconds(stamp: str) -> int:
    return int(to_seconds(parse_stamp(stamp)))


@dataclass
class Outputs:
    """The seven outputs (§6.7): a written value, or automatic switching (``NO``)."""

    hardware: Hardware
    manual: dict[int, str] = field(default_factory=dict)  # output -> "0" | "1" | "NO"
    usable: dict[int, bool] = field(default_factory=dict)  # device configured (§6.7.1)
    scheduled: dict[int, set[int]] = field(default_factory=dict)  # output -> channels powering
    held_until: dict[int, float] = field(default_factory=dict)  # module seconds
    on_since: dict[int, float] = field(default_factory=dict)  # module seconds, when on
    applied: dict[int, bool] = field(default_factory=dict)

    def is_on(self, output: int) -> bool:
        return self.applied.get(output, False)

    def update(self, now: float, offset: float) -> None:
        """Recompute every output's state at module time ``now`` and tell the hardware."""
        usable, applied = self.usable, self.applied
        for output in range(1, 8):
            if not usable.get(output, False):
                on = False
            elif (manual := self.manual.get(output, "NO")) != "NO":
                on = manual == "1"
            else:
                on = bool(self.scheduled.get(output)) or self.held_until.get(output, -1) > now
            if on != applied.get(output, False):
                self.applied[output] = on
                if on:
                    self.on_since[output] = now
                else:
                    self.on_since.pop(output, None)
                self.hardware.set_output(output, on, now - offset)


RowSink = Callable[[int, list[str]], None]
#: Told of every sampling instant: its module second, the channels sampled, rows written?
SampleObserver = Callable[[int, list["ChannelRun"], bool], None]

log = logging.getLogger("sondalog.ala1.sampling")


class FaultLog:
    """Internal errors of channels, logged at most once a minute per channel and cause."""

    INTERVAL = 60.0

    def __init__(self) -> None:
        self._last: dict[tuple[int, str], float] = {}

    def report(self, channel: int, exc: Exception, host_t: float) -> None:
        key = (channel, type(exc).__name__)
        last = self._last.get(key)
        if last is not None and 0 <= host_t - last < self.INTERVAL:
            return
        self._last[key] = host_t
        log.error(
            "channel %d: internal error while sampling (%s: %s); no valid value",
            channel,
            type(exc).__name__,
            exc,
        )


class Sampler:
    """Runs the channels' schedules and decides which values reach the record."""

    def __init__(self, measurer: Measurer, outputs: Outputs) -> None:
        self.measurer = measurer
        self.outputs = outputs
        self.faults = FaultLog()
        self.runs: dict[int, ChannelRun] = {}
        self.max_number = 1
        self._switching = False  # a channel's input is switched by an output (§6.5.13)
        self.observer: SampleObserver | None = None  # messages (§6.14.6, §6.14.7)

    def configure(self, configs: list[ChannelConfig], max_number: int, now: int) -> None:
        """New channel parameters; channels whose sampling changed restart their schedule."""
        old = self.runs
        self.runs = {}
        self.max_number = max_number
        for cfg in configs:
            run = old.get(cfg.number)
            if run is None or _sampling_changed(run.cfg, cfg):
                fresh = ChannelRun(cfg)
                if run is not None:
                    # §6.5.9, §6.5.16.3: the last sample and the last recorded value stay
                    # until a new sample replaces them; only the schedule starts again.
                    fresh.sample, fresh.sampled = run.sample, run.sampled
                    fresh.recorded, fresh.event_active = run.recorded, run.event_active
                run = fresh
                run.schedule(now)
            else:
                run.cfg, run.measure = cfg, None
            self.runs[cfg.number] = run
        for output in list(self.outputs.scheduled):
            self.outputs.scheduled[output].clear()
        self._switching = any(run.cfg.switches for run in self.runs.values())

    def reschedule(self, now: int) -> None:
        """The clock was set: every channel finds its next sample from the new time."""
        for run in self.runs.values():
            run.schedule(now)

    def _scan(self) -> tuple[int | None, list[ChannelRun], int | None, float | None]:
        """One pass: the next sample time and the channels due then, the next switch
        power-on, and the next hold expiry (module times)."""
        held = self.outputs.held_until
        hold = min(held.values()) if held else None
        sample: int | None = None
        due: list[ChannelRun] = []
        power: int | None = None
        scheduled = self.outputs.scheduled
        switching = self._switching
        for run in self.runs.values():
            t = run.next_t
            if t is None:
                continue
            if sample is None or t < sample:
                sample, due = t, [run]
            elif t == sample:
                due.append(run)
            if not switching:
                continue
            for output, advance in run.cfg.switches:
                if (
                    advance > 0
                    and run.cfg.number not in scheduled.get(output, ())
                    and (power is None or t - advance < power)
                ):
                    power = t - advance
        return sample, due, power, hold

    def next_event(self) -> float | None:
        """Module time of the next thing the sampler must do."""
        sample, _, power, hold = self._scan()
        return min((t for t in (sample, power, hold) if t is not None), default=None)

    def run_until(self, target: float, offset: float, sink: RowSink) -> None:
        """Process every event up to module time ``target``; rows go to ``sink``."""
        outputs = self.outputs
        while True:
            sample, due, power, hold = self._scan()
            if hold is not None and hold <= target and (sample is None or hold <= sample):
                for output, until in list(outputs.held_until.items()):
                    if until <= hold:
                        del outputs.held_until[output]
                outputs.update(hold, offset)
                continue
            if power is not None and power <= target and (sample is None or power < sample):
                self._power_on(power, offset)
                continue
            if sample is None or sample > target:
                outputs.update(target, offset)
                return
            if hold is None and not self._switching and len(due) == len(self.runs):
                self._series(sample, due, target, offset, sink)
            else:
                self._sample(sample, due, offset, sink)

    def _power_on(self, t: int, offset: float) -> None:
        """§6.5.13: power the switches whose advance window opens at ``t``."""
        scheduled = self.outputs.scheduled
        for run in self.runs.values():
            if run.next_t is None:
                continue
            for output, advance in run.cfg.switches:
                if advance > 0 and run.next_t - advance <= t:
                    scheduled.setdefault(output, set()).add(run.cfg.number)
        self.outputs.update(float(t), offset)

    def _sample(self, t: int, due: list[ChannelRun], offset: float, sink: RowSink) -> None:
        outputs = self.outputs
        switched = self._switching and any(run.cfg.switches for run in due)
        if switched:
            for run in due:
                for output, _ in run.cfg.switches:
                    outputs.scheduled.setdefault(output, set()).add(run.cfg.number)
            outputs.update(float(t), offset)
        self._instant(t, due, offset, sink)
        if switched:
            for run in due:
                for output, _ in run.cfg.switches:
                    outputs.scheduled.get(output, set()).discard(run.cfg.number)
            outputs.update(float(t), offset)

    def _series(
        self, t: int, due: list[ChannelRun], target: float, offset: float, sink: RowSink
    ) -> None:
        """Every channel samples at ``t`` and nothing is switched or held: when they share
        one period, the instants ``t``, ``t + period``, ... up to ``target`` one after the
        other, without looking for the next event in between (issue 11)."""
        period = due[0].cfg.period
        if any(run.cfg.period != period for run in due):
            self._sample(t, due, offset, sink)
            return
        while t <= target:
            self._instant(t, due, offset, sink)
            t += period

    def _instant(self, t: int, due: list[ChannelRun], offset: float, sink: RowSink) -> None:
        """One sampling instant: measure the channels due, store the row, tell the observer."""
        fields: dict[int, str] = {}
        self.measurer.begin_instant()
        try:
            self._measure_due(t, t - offset, due, fields)
        finally:
            self.measurer.end_instant()
        if fields:
            sink(t, [fields.get(n, "") for n in range(1, self.max_number + 1)])
        if self.observer is not None:
            self.observer(t, due, bool(fields))

    def _measure_due(
        self, t: int, host_t: float, due: list[ChannelRun], fields: dict[int, str]
    ) -> None:
        """Measure the channels due at ``t``; the values written go to ``fields``."""
        decide, max_number = self._decide, self.max_number
        for run in due:
            cfg = run.cfg
            last = run.last_t
            run.last_t = t
            run.next_t = t + cfg.period
            try:
                measure = run.measure
                if measure is None:
                    measure = run.measure = self.measurer.compiled(cfg)
                # the window (for pulses): whole seconds since the last sample
                value = measure(host_t, t - last if last is not None else cfg.period)
                run.sample, run.sampled = value, True
                if value is not None and run.avg_n + 1 < cfg.average:
                    # What :meth:`_decide` does with a sample that does not complete the
                    # average (§6.5.15), without the call: most samples of an average.
                    run.avg_sum += value
                    run.avg_n += 1
                    continue
                written = decide(run, value)
            except Exception as exc:
                # Defence in depth (issue 9): one channel's failure is that channel's "no
                # valid value" at this instant; the other channels and the timer go on.
                self.faults.report(cfg.number, exc, host_t)
                run.sample, run.sampled = None, True
                try:
                    written = self._decide(run, None)
                except Exception:
                    written = None
            if written is not None and cfg.number <= max_number:
                fields[cfg.number] = written

    @staticmethod
    def _decide(run: ChannelRun, value: float | None) -> str | None:
        """§6.5.15, §6.5.16: averaging, then the change and samples conditions."""
        cfg = run.cfg
        if cfg.average > 0:
            if value is not None:
                run.avg_sum += value
                run.avg_n += 1
            if run.avg_n < cfg.average:
                return None
            value = run.avg_sum / run.avg_n
            run.avg_sum, run.avg_n = 0.0, 0
        text = format_value(cfg, value)
        run.since_write += 1
        write: str | None = None
        change = cfg.change
        if change == _ZERO:
            write = text
        elif change != _NEVER:
            if cfg.type == 6:
                # §6.5.16.1: events per period; one 0 when the condition stops holding
                if text and Decimal(text) >= change:
                    write, run.event_active = text, True
                elif run.event_active:
                    write, run.event_active = format_value(cfg, 0.0), False
            elif run.recorded is None or _changed(run.recorded, text, change):
                write = text
        if write is None and cfg.samples > 0 and run.since_write >= cfg.samples:
            write = text
        if write is not None:
            run.recorded = write
            run.since_write = 0
        return write


def _changed(old: str, new: str, change: Decimal) -> bool:
    if not old or not new:
        return old != new
    return abs(Decimal(new) - Decimal(old)) >= change


def _sampling_changed(old: ChannelConfig, new: ChannelConfig) -> bool:
    return (old.period, old.start, old.average, old.type) != (
        new.period,
        new.start,
        new.average,
        new.type,
    )
