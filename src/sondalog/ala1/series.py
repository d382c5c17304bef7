"""Many sampling instants at once, channel by channel (issue 24; §6.5.13-§6.5.16, §6.14.6-7).

The event-by-event path (:meth:`~sondalog.ala1.sampling.Sampler.run_until`) powers each
switched sensor ``advance`` seconds before its sample (§6.5.13), measures every channel due,
writes the row and switches the sensors off again, instant after instant. When the hardware's
readings depend only on the time and on which outputs are on (``pure_readings``: the
simulation), a stretch of instants gives the same record computed the other way round: each
input's readings for every instant of the stretch, then each channel's values, averages and
record conditions (§6.5.15-§6.5.16), then the rows. What is on at each instant is known in
advance: the outputs of the channels sampled then and of the channels whose switch-on delay
has begun, and the outputs written by hand. A stretch ends at an instant after which no delay
is running, so the event-by-event path goes on from exactly the state it would have reached.

Falls back to the event-by-event path (returns False): a hold of an on-demand read is running
(§6.9), a switch-on delay as long as its channel's period, hardware that is not
``pure_readings``, the interpreted reference measurement (``Measurer.fast`` False), an
observer of instants without a series observer, or fewer than two instants before the target.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable, Hashable
from decimal import Decimal
from typing import Protocol

from sondalog.ala1.columns import Column, Source, Value, channel_plan, mapped, plain_column
from sondalog.ala1.measure import ChannelConfig, Measurer, format_value
from sondalog.ala1.runs import ChannelRun, FaultLog, Outputs, decide, record

#: Instants of the most frequent channel in one stretch (bounds the memory of a stretch).
CHUNK = 4096
#: What a series observer is told: the instants that wrote rows, and every channel sampled
#: with its instants and samples (unformatted; None: no valid value).
Samples = dict[int, tuple[ChannelConfig, list[int], list[Value]]]
SeriesObserver = Callable[[list[int], Samples], None]
#: Rows go to the sink: the module second and the fields of channels 1..max number.
RowSink = Callable[[int, list[str]], None]


class Sampler(Protocol):
    """What a series needs of :class:`sondalog.ala1.sampling.Sampler`."""

    measurer: Measurer
    outputs: Outputs
    faults: FaultLog
    runs: dict[int, ChannelRun]
    max_number: int

    @property
    def observer(self) -> object: ...

    series_observer: SeriesObserver | None


def _next_at_or_after(run: ChannelRun, t: int) -> int:
    start, period = run.next_t, run.cfg.period
    assert start is not None
    return start if t <= start else start + math.ceil((t - start) / period) * period


def _powered(runs: list[ChannelRun], t: int) -> dict[int, set[int]]:
    """The switched outputs at sample instant ``t``: channel numbers by output."""
    on: dict[int, set[int]] = {}
    for run in runs:
        n = _next_at_or_after(run, t)
        number = run.cfg.number
        for output, advance in run.cfg.switches:
            if n == t or (advance > 0 and n - advance < t):
                on.setdefault(output, set()).add(number)
    return on


def _clean(runs: list[ChannelRun], t: int) -> bool:
    """No switch-on delay runs on after the sample at ``t`` (channels sampled at ``t``
    start theirs after it: an advance is shorter than the period)."""
    for run in runs:
        n = _next_at_or_after(run, t)
        if n == t:
            continue
        for _, advance in run.cfg.switches:
            if advance > 0 and n - advance < t:
                return False
    return True


def run_series(sampler: Sampler, t0: int, target: float, offset: float, sink: RowSink) -> bool:
    """Sample every instant from ``t0`` (the next sample) up to ``target`` (at most a chunk)
    channel by channel; False when the event-by-event path must take them."""
    outputs = sampler.outputs
    if (
        outputs.held_until
        or not sampler.measurer.fast
        or not getattr(outputs.hardware, "pure_readings", False)
        or (sampler.observer is not None and sampler.series_observer is None)
    ):
        return False
    runs = [run for run in sampler.runs.values() if run.next_t is not None]
    if any(advance >= run.cfg.period for run in runs for _, advance in run.cfg.switches):
        return False
    end = min(math.floor(target), t0 + min(run.cfg.period for run in runs) * CHUNK)
    cohorts: dict[tuple[int, int], list[int]] = {}
    for run in runs:
        key = (run.next_t or 0, run.cfg.period)
        if key not in cohorts and key[0] <= end:
            cohorts[key] = list(range(key[0], end + 1, key[1]))
    if len(cohorts) == 1:
        instants = next(iter(cohorts.values()))
    else:
        instants = sorted({t for times in cohorts.values() for t in times})
    switched = [run for run in runs if run.cfg.switches]
    last = len(instants) - 1
    while last >= 0 and switched and not _clean(switched, instants[last]):
        last -= 1
    if last < 1:
        return False
    stop = instants[last]
    for (start, period), times in cohorts.items():
        del times[max(0, (stop - start) // period + 1) :]  # (a cohort may start after stop)
    _sample_series(sampler, runs, cohorts, instants[: last + 1], offset, sink)
    return True


def _sample_series(
    sampler: Sampler,
    runs: list[ChannelRun],
    cohorts: dict[tuple[int, int], list[int]],
    instants: list[int],
    offset: float,
    sink: RowSink,
) -> None:
    """Sample the cohorts' ``instants``: read the inputs with the outputs on as at each
    instant, compute, decide, store the rows, tell the observer; the outputs end as after
    the last sample (every switched one off)."""
    outputs = sampler.outputs
    switched = [run for run in runs if run.cfg.switches]
    # which outputs are on at each instant: instants grouped by it (one group without switches)
    groups: dict[frozenset[int], list[int]] = {}
    if len(cohorts) == 1 and all(run.next_t == instants[0] for run in switched):
        groups[frozenset(_powered(switched, instants[0]))] = instants  # all due, always
    else:
        for t in instants:
            groups.setdefault(frozenset(_powered(switched, t)), []).append(t)
    # every channel's sources and calculation; sources read once per cohort
    plans: dict[int, tuple[tuple[Source, ...], Callable[..., Value]]] = {}
    for run in runs:
        plans[run.cfg.number] = channel_plan(sampler.measurer, run.cfg)
    columns: dict[tuple[tuple[int, int], Hashable], Column] = {}
    for on_outputs, group in groups.items():
        scheduled = outputs.scheduled
        for output in set(scheduled) | on_outputs:
            scheduled[output] = {0} if output in on_outputs else set()
        outputs.update(float(group[0]), offset)
        members = set(group) if len(groups) > 1 else None
        done: set[tuple[tuple[int, int], Hashable]] = set()
        for run in runs:
            key = (run.next_t or 0, run.cfg.period)
            times = cohorts.get(key)
            if not times:
                continue
            window0 = key[0] - run.last_t if run.last_t is not None else run.cfg.period
            for src in plans[run.cfg.number][0]:
                if (key, src.key) not in done:
                    done.add((key, src.key))
                    _read(columns, key, src, times, members, offset, window0, run.cfg.period)
    for numbers in outputs.scheduled.values():
        numbers.clear()
    samples: Samples = {}
    written: dict[int, dict[int, str]] = {}
    for run in runs:
        key = (run.next_t or 0, run.cfg.period)
        times = cohorts.get(key)
        if not times:
            continue
        sources, calc = plans[run.cfg.number]
        got = [columns[key, src.key] for src in sources]
        many = plain_column(run.cfg)
        values = _values(sources, calc, got) if many is None else _plain(many, calc, got[0])
        samples[run.cfg.number] = (run.cfg, times, values.values)
        written[run.cfg.number] = _decide_all(sampler, run, times, values, offset)
        run.last_t = times[-1]
        run.next_t = times[-1] + run.cfg.period
    outputs.update(float(instants[-1]), offset)
    rows = sorted({t for texts in written.values() for t in texts})
    fields = [written.get(n, {}) for n in range(1, sampler.max_number + 1)]
    for t in rows:
        sink(t, [texts.get(t, "") for texts in fields])
    if sampler.series_observer is not None:
        sampler.series_observer(rows, samples)


def _read(
    columns: dict[tuple[tuple[int, int], Hashable], Column],
    cohort: tuple[int, int],
    src: Source,
    times: list[int],
    members: set[int] | None,
    offset: float,
    window0: int,
    period: int,
) -> None:
    """Read ``src`` at the cohort's ``times`` that belong to the current group (all when
    ``members`` is None) into ``columns``."""
    read = src.read
    if read is None:
        if (cohort, src.key) not in columns:
            columns[cohort, src.key] = Column([src.constant] * len(times))
        return
    if members is None:
        index: list[int] | range = range(len(times))
        hosts = [t - offset for t in times]
    else:
        index = [k for k, t in enumerate(times) if t in members]
        hosts = [times[k] - offset for k in index]
    windows = [window0 if k == 0 else period for k in index] if src.windowed else []
    try:
        if src.counts is not None:
            got = Column(src.counts(hosts, windows))
        elif src.column is not None:
            got = Column(src.column(hosts))
        else:
            got = mapped(read, hosts, windows) if src.windowed else mapped(read, hosts)
    except Exception:  # (a reading that raises: read one by one, it is that one's fault)
        got = mapped(read, hosts, windows) if src.windowed else mapped(read, hosts)
    column = columns.get((cohort, src.key))
    if column is None:
        if members is None:
            columns[cohort, src.key] = got
            return
        column = columns[cohort, src.key] = Column([None] * len(times))
    for i, k in enumerate(index):
        column.values[k] = got.values[i]
        if i in got.faults:
            column.faults[k] = got.faults[i]


def _plain(
    many: Callable[[list[Value]], list[Value]], calc: Callable[..., Value], got: Column
) -> Column:
    """:func:`_values` of a one-input channel without tables, in one comprehension."""
    try:
        result = Column(many(got.values))
    except Exception:  # (computed one by one: that value's fault)
        result = mapped(calc, got.values)
    for k, exc in got.faults.items():
        result.faults[k] = exc
        result.values[k] = None
    for k in result.faults:
        result.values[k] = None
    return result


def _values(sources: tuple[Source, ...], calc: Callable[..., Value], got: list[Column]) -> Column:
    """The channel's values from its sources' columns; a fault of a source is the channel's
    fault (type 9: the second input counts only when the first has a value)."""
    result = mapped(calc, *(column.values for column in got))
    faults = result.faults
    first = got[0]
    for k, exc in first.faults.items():
        faults[k] = exc
    if len(got) > 1:
        for k, exc in got[1].faults.items():
            if k not in first.faults and first.values[k] is not None:
                faults[k] = exc
    for k in faults:
        result.values[k] = None
    return result


def _decide_all(
    sampler: Sampler, run: ChannelRun, times: list[int], values: Column, offset: float
) -> dict[int, str]:
    """§6.5.15-§6.5.16 for every sample of ``run``: the texts written, by instant (as
    :meth:`Sampler._measure_due` does sample by sample)."""
    cfg = run.cfg
    if cfg.average > 0:
        return _averaged(sampler, run, times, values, offset)
    report = sampler.faults.report
    faults = values.faults
    written: dict[int, str] = {}
    sample: Value = None
    texts: list[str | None]
    try:
        texts = _texts(cfg, values.values)
    except Exception:  # (decide meets it again below, sample by sample)
        texts = [None] * len(values.values)
    quiet = _Quiet(cfg)
    samples = cfg.samples
    for k, value in enumerate(values.values):
        sample = value
        shown = texts[k]
        if (
            shown
            and shown in quiet
            and run.recorded is not None
            and not run.event_active
            and (cfg.type == 6 or shown == run.recorded)
            and not (faults and k in faults)
            and not (samples > 0 and run.since_write + 1 >= samples)
        ):
            run.since_write += 1  # runs.record of a value that writes nothing, without the call
            continue
        if faults and k in faults:
            # (Sampler._measure_due's except branch)
            report(cfg.number, faults[k], times[k] - offset)
            try:
                text = decide(run, None)
            except Exception:
                text = None
        else:
            try:
                shown = texts[k]
                text = decide(run, value) if shown is None else record(run, shown)
            except Exception as exc:
                report(cfg.number, exc, times[k] - offset)
                sample = None
                try:
                    text = decide(run, None)
                except Exception:
                    text = None
        if text is not None and cfg.number <= sampler.max_number:
            written[times[k]] = text
    run.sample, run.sampled = sample, True
    return written


class _Quiet:
    """Texts for which :func:`runs.record` writes nothing by the change condition: for a
    type 6 channel those below the change (while no event is active), for the others any
    text equal to the last recorded one when the change is positive (§6.5.16.1)."""

    def __init__(self, cfg: ChannelConfig) -> None:
        self.cfg = cfg
        change = cfg.change
        self.events = cfg.type == 6 and change > 0
        self.same = cfg.type != 6 and change > 0
        self._below: dict[str, bool] = {}

    def __contains__(self, text: object) -> bool:
        if self.same:
            return True  # (the caller compares with the recorded text)
        if not self.events or not isinstance(text, str):
            return False
        below = self._below.get(text)
        if below is None:
            below = self._below[text] = Decimal(text) < self.cfg.change
        return below


def _texts(cfg: ChannelConfig, values: list[Value]) -> list[str | None]:
    """``format_value`` of each value; repeated values (events, a steady signal) looked up."""
    shown: dict[Value, str] = {}
    return [
        shown[value] if value in shown else shown.setdefault(value, format_value(cfg, value))
        for value in values
    ]


def _averaged(
    sampler: Sampler, run: ChannelRun, times: list[int], values: Column, offset: float
) -> dict[int, str]:
    """:func:`_decide_all` of an averaging channel (§6.5.15): a sample without a valid value
    does not count, and :func:`decide` of one is a no-op; the samples of each average are
    summed in order as the event-by-event path adds them, then :func:`decide` adds the last
    one and decides on the average."""
    cfg, report = run.cfg, sampler.faults.report
    for k, exc in values.faults.items():
        report(cfg.number, exc, times[k] - offset)
    samples = values.values
    if None in samples:
        index = [k for k, value in enumerate(samples) if value is not None]
        valid = [samples[k] for k in index]
    else:
        index, valid = list(range(len(samples))), samples
    written: dict[int, str] = {}
    last = len(samples) - 1
    sample = samples[-1]
    i = 0
    while True:
        need = cfg.average - run.avg_n
        if i + need > len(valid):
            break
        run.avg_sum = functools.reduce(operator.add, valid[i : i + need - 1], run.avg_sum)
        run.avg_n = cfg.average - 1
        k = index[i + need - 1]
        try:
            text = decide(run, valid[i + need - 1])
        except Exception as exc:
            report(cfg.number, exc, times[k] - offset)
            if k == last:
                sample = None
            try:
                text = decide(run, None)
            except Exception:
                text = None
        if text is not None and cfg.number <= sampler.max_number:
            written[times[k]] = text
        i += need
    run.avg_sum = functools.reduce(operator.add, valid[i:], run.avg_sum)
    run.avg_n += len(valid) - i
    run.sample, run.sampled = sample, True
    return written
