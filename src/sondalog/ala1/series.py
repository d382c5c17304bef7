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
(§6.9), a switch-on delay as long as its channel's period, a sensor powered by a delay that
began before the clock was set back, hardware that is not
``pure_readings``, the interpreted reference measurement (``Measurer.fast`` False), an
observer of instants without a series observer, or fewer than two instants before the target.
"""

from __future__ import annotations

import bisect
import math
import operator
from collections.abc import Callable, Hashable
from typing import Protocol

from sondalog.ala1.columns import (
    Calc,
    Column,
    Many,
    Source,
    Value,
    channel_column,
    channel_plan,
    mapped,
)
from sondalog.ala1.conditions import decide_series
from sondalog.ala1.measure import ChannelConfig, Measurer
from sondalog.ala1.runs import ChannelRun, FaultLog, Outputs

#: Instants of the most frequent channel in one stretch (bounds the memory of a stretch).
CHUNK = 4096
#: What a series observer is told: the instants that wrote rows, and every channel sampled
#: with its instants and samples (unformatted; None: no valid value).
Samples = dict[int, tuple[ChannelConfig, list[int], list[Value]]]
SeriesObserver = Callable[[list[int], Samples], None]
#: Rows go to the sink: the module second and the fields of channels 1..max number.
RowSink = Callable[[int, list[str]], None]
#: A stretch's rows at once: their module seconds (ascending) and their fields.
RowsSink = Callable[[list[int], list[list[str]]], None]


class Sampler(Protocol):
    """What a series needs of :class:`sondalog.ala1.sampling.Sampler`."""

    measurer: Measurer
    outputs: Outputs
    faults: FaultLog
    runs: dict[int, ChannelRun]
    max_number: int
    #: :func:`channel_column` by channel, with the configuration and tables it was made of.
    columns: dict[int, tuple[ChannelConfig, object, Many | None]]

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


def _groups(
    switched: list[ChannelRun], cohorts: dict[tuple[int, int], list[int]], instants: list[int]
) -> dict[frozenset[int], list[int]]:
    """The ``instants`` grouped by the outputs on at each (:func:`_powered` of every instant):
    an output is on at the instants its channels sample and within their switch-on delays
    before each of their samples (none runs on past the last instant: :func:`_clean`)."""
    masks = [0] * len(instants)
    first, step = instants[0], instants[1] - instants[0] if len(instants) > 1 else 0
    gap = min(map(operator.sub, instants[1:], instants), default=0)  # (the least of two)
    # a progression: no gap shorter than the first and the ends as far apart as its steps
    # (the ends alone are not enough: gaps of 5, 2 and 8 s end where three of 5 s do)
    if step > 0 and gap == step and instants[-1] - first == (len(instants) - 1) * step:
        where: dict[int, int] = {}  # (looked up only where an index is not worked out)
    else:
        where, step = {t: i for i, t in enumerate(instants)}, 0
    right = bisect.bisect_right
    sampled: dict[tuple[int, int], int] = {}  # outputs on at each cohort's samples, as bits
    for run in switched:
        key = (run.next_t or 0, run.cfg.period)
        times = cohorts.get(key)
        if not times:
            continue
        for output, advance in run.cfg.switches:
            bit = 1 << output
            sampled[key] = sampled.get(key, 0) | bit
            if advance > gap:  # instants in (t - advance, t): the delay before sample t
                where = where or {t: i for i, t in enumerate(instants)}
                ends = [w for t in times if (w := where[t]) and instants[w - 1] > t - advance]
                for w in ends:
                    for i in range(right(instants, instants[w] - advance), w):
                        masks[i] |= bit
    for key, bits in sampled.items():
        times = cohorts[key]
        if len(times) == len(instants):  # (a cohort sampled at every instant)
            masks = [mask | bits for mask in masks]
        elif step and key[1] % step == 0 and (times[0] - first) % step == 0:
            for i in range((times[0] - first) // step, len(instants), key[1] // step):
                masks[i] |= bits  # (its instants every period / step of the progression)
        else:
            where = where or {t: i for i, t in enumerate(instants)}
            for t in times:
                masks[where[t]] |= bits
    by_mask: dict[int, list[int]] = {}
    for t, mask in zip(instants, masks, strict=True):
        group = by_mask.get(mask)
        if group is None:
            by_mask[mask] = [t]
        else:
            group.append(t)
    outputs = {output for run in switched for output, _ in run.cfg.switches}
    return {
        frozenset(output for output in outputs if mask >> output & 1): group
        for mask, group in by_mask.items()
    }


def _stale(sampler: Sampler, t0: int) -> bool:
    """An output powered for a channel whose switch-on delay did not begin by the schedule:
    the clock was set back while it ran (§6.2). The event-by-event path keeps it on until
    that channel's next sample; so does the series path, by leaving the instants to it."""
    for output, numbers in sampler.outputs.scheduled.items():
        for number in numbers:
            run = sampler.runs.get(number)
            n = None if run is None else run.next_t
            advance = None if run is None else dict(run.cfg.switches).get(output)
            if n is None or advance is None or not (n == t0 or (advance > 0 and n - advance < t0)):
                return True
    return False


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


def run_series(
    sampler: Sampler,
    t0: int,
    target: float,
    offset: float,
    sink: RowSink,
    many: RowsSink | None = None,
) -> bool:
    """Sample every instant from ``t0`` (the next sample) up to ``target`` (at most a chunk)
    channel by channel; False when the event-by-event path must take them. The rows go to
    ``many`` at once (else to ``sink`` one by one)."""
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
    if _stale(sampler, t0):
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
        instants = _union(cohorts)
    switched = [run for run in runs if run.cfg.switches]
    last = len(instants) - 1
    while last >= 0 and switched and not _clean(switched, instants[last]):
        last -= 1
    if last < 1:
        return False
    stop = instants[last]
    for (start, period), times in cohorts.items():
        del times[max(0, (stop - start) // period + 1) :]  # (a cohort may start after stop)
    _sample_series(sampler, runs, cohorts, instants[: last + 1], offset, sink, many)
    return True


def _union(cohorts: dict[tuple[int, int], list[int]]) -> list[int]:
    """The instants of the ``cohorts`` (each to the same end) in order: a copy of the
    cohort's whose instants hold every other's (its period divides theirs, in step with
    their starts), else sorted."""
    for (start, period), times in cohorts.items():
        if all(s >= start and (s - start) % period == 0 == p % period for s, p in cohorts):
            return times.copy()
    return sorted(set().union(*cohorts.values()))


def _sample_series(
    sampler: Sampler,
    runs: list[ChannelRun],
    cohorts: dict[tuple[int, int], list[int]],
    instants: list[int],
    offset: float,
    sink: RowSink,
    many: RowsSink | None,
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
        groups = _groups(switched, cohorts, instants)
    # every channel's sources and calculation; sources read once per cohort
    plans: dict[int, tuple[tuple[Source, ...], Calc]] = {}
    for run in runs:
        plans[run.cfg.number] = channel_plan(sampler.measurer, run.cfg)
    columns: dict[tuple[tuple[int, int], Hashable], Column] = {}
    hosts = {key: [t - offset for t in times] for key, times in cohorts.items()}
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
            window0 = _window0(run, key[0])
            for src in plans[run.cfg.number][0]:
                name = (src.key, window0) if src.windowed else src.key
                if (key, name) not in done:
                    done.add((key, name))
                    at = (times, hosts[key], members)
                    _read(columns, (key, name), src, at, offset, window0, run.cfg.period)
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
        window0 = _window0(run, key[0])
        got = [columns[key, (src.key, window0) if src.windowed else src.key] for src in sources]
        values = _values(sources, calc, _channel_column(sampler, run.cfg), got)
        samples[run.cfg.number] = (run.cfg, times, values.values)
        decided = decide_series(run, times, values, offset, sampler.faults.report)
        if run.cfg.number <= sampler.max_number:
            written[run.cfg.number] = decided
        run.last_t = times[-1]
        run.next_t = times[-1] + run.cfg.period
    outputs.update(float(instants[-1]), offset)
    # each row's fields filled text by text (a channel writes at few of the instants)
    table: dict[int, list[str]] = {}
    blank = [""] * sampler.max_number
    for number, texts in written.items():
        place = number - 1
        for t, text in texts.items():
            fields = table.get(t)
            if fields is None:
                fields = table[t] = blank.copy()
            fields[place] = text
    rows = sorted(table)
    if many is not None:
        many(rows, [table[t] for t in rows])
    else:
        for t in rows:
            sink(t, table[t])
    if sampler.series_observer is not None:
        sampler.series_observer(rows, samples)


def _channel_column(sampler: Sampler, cfg: ChannelConfig) -> Many | None:
    """:func:`channel_column` of ``cfg``, kept while the channel's configuration and the
    tables stay (its tables remember the values they computed)."""
    tables = sampler.measurer.tables
    kept = sampler.columns.get(cfg.number)
    if kept is not None and kept[0] == cfg and kept[1] is tables:
        return kept[2]
    many = channel_column(sampler.measurer, cfg)
    sampler.columns[cfg.number] = (cfg, tables, many)
    return many


def _window0(run: ChannelRun, first: int) -> int:
    """The counting window of ``run``'s first sample at ``first`` (pulses): whole seconds
    since its last sample."""
    return first - run.last_t if run.last_t is not None else run.cfg.period


def _read(
    columns: dict[tuple[tuple[int, int], Hashable], Column],
    name: tuple[tuple[int, int], Hashable],
    src: Source,
    at: tuple[list[int], list[float], set[int] | None],
    offset: float,
    window0: int,
    period: int,
) -> None:
    """Read ``src`` into ``columns[name]`` at the cohort's times (module and host times) that
    belong to the current group (all when its members are None)."""
    times, all_hosts, members = at
    read = src.read
    if read is None:
        if name not in columns:
            columns[name] = Column([src.constant] * len(times))
        return
    if members is None:
        index: list[int] | range = range(len(times))
        hosts = all_hosts
    else:
        index = [k for k, t in enumerate(times) if t in members]
        hosts = [all_hosts[k] for k in index]
    windows: list[int] = []
    if src.windowed:  # (every window a period, but the first sample's since the last)
        windows = [period] * len(index)
        if index and index[0] == 0:
            windows[0] = window0
    try:
        if src.counts is not None:
            got = Column(src.counts(hosts, windows))
        elif src.column is not None:
            got = Column(src.column(hosts))
        else:
            got = mapped(read, hosts, windows) if src.windowed else mapped(read, hosts)
    except Exception:  # (a reading that raises: read one by one, it is that one's fault)
        got = mapped(read, hosts, windows) if src.windowed else mapped(read, hosts)
    column = columns.get(name)
    if column is None:
        if members is None:
            columns[name] = got
            return
        column = columns[name] = Column([None] * len(times))
    for i, k in enumerate(index):
        column.values[k] = got.values[i]
        if i in got.faults:
            column.faults[k] = got.faults[i]


def _values(
    sources: tuple[Source, ...], calc: Calc, many: Many | None, got: list[Column]
) -> Column:
    """The channel's values from its sources' columns (at once by ``many`` where it can, else
    value by value); a fault of a source is the channel's fault (type 9: the second input
    counts only when the first has a value)."""
    result: Column | None = None
    if many is not None:
        try:
            result = Column(many(*(column.values for column in got)))
        except Exception:  # (computed one by one: that value's fault)
            result = None
    if result is None:
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
