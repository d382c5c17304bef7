"""Scheduled sampling and the switches (§6.5.13-§6.5.16, §6.7, §6.9; spec notes §7).

Times here are *module* seconds (the module clock as seconds since 1970); the hardware is
asked at the matching host time. A channel with period P and start S samples at S + k*P; a
start in the past moves forward by whole periods. Channels sampled in the same second share
one row of type 1. A switched sensor is powered ``advance`` seconds before its sample and
switched off after it, unless an on-demand read holds it (``command channel switch hold``).
"""

from __future__ import annotations

from collections.abc import Callable

from sondalog.ala1.columns import Many
from sondalog.ala1.measure import ChannelConfig, Measurer
from sondalog.ala1.runs import ChannelRun, FaultLog, Outputs, decide
from sondalog.ala1.series import RowsSink, SeriesObserver, run_series

__all__ = [
    "ChannelRun", "FaultLog", "Outputs", "RowSink", "RowsSink", "SampleObserver", "Sampler",
]  # fmt: skip


RowSink = Callable[[int, list[str]], None]
#: Told of every sampling instant: its module second, the channels sampled, rows written?
SampleObserver = Callable[[int, list["ChannelRun"], bool], None]


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
        #: The observer's view of many instants at once (:mod:`sondalog.ala1.series`); a
        #: sampler with an observer but without this one samples instant by instant.
        self.series_observer: SeriesObserver | None = None
        #: The series path's channel calculations, kept while configuration and tables stay.
        self.columns: dict[int, tuple[ChannelConfig, object, Many | None]] = {}

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

    def run_until(
        self, target: float, offset: float, sink: RowSink, many: RowsSink | None = None
    ) -> None:
        """Process every event up to module time ``target``; rows go to ``sink`` (a
        stretch's rows at once to ``many``, when given: :func:`~.series.run_series`)."""
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
            if hold is None and run_series(self, sample, target, offset, sink, many):
                continue
            if hold is None and not self._switching and len(due) == len(self.runs):
                self._series(sample, due, target, offset, sink)
            else:
                self._sample(sample, due, offset, sink)

    _decide = staticmethod(decide)

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


def _sampling_changed(old: ChannelConfig, new: ChannelConfig) -> bool:
    return (old.period, old.start, old.average, old.type) != (
        new.period,
        new.start,
        new.average,
        new.type,
    )
