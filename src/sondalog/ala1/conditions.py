"""What a series of samples makes of the record (issue 24; §6.5.15-§6.5.16).

:func:`runs.decide` takes one sample: averaging (§6.5.15), then the change and samples
conditions (§6.5.16). Here the same decisions for all the samples of one channel in a stretch
(:mod:`sondalog.ala1.series`) at once: the averages summed in the order the event-by-event path
adds them, each average formatted, then the record conditions over the texts, with the very
texts, the very rows and the very state (:class:`~sondalog.ala1.runs.ChannelRun`) after them.

The bulk computation touches the run's state only when it is done; anything unexpected (a
sample that raises) takes the sample-by-sample way from the same state.
"""

from __future__ import annotations

import functools
import operator
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from decimal import ROUND_CEILING, Decimal
from itertools import repeat

from sondalog.ala1.columns import Column, Value
from sondalog.ala1.curves import has_none
from sondalog.ala1.measure import (
    KNOWN_UNITS,
    KNOWN_UNITS_MAX,
    format_value,
    format_values,
    rendered_lately,
    texts_by_units,
)
from sondalog.ala1.rendering import value_units
from sondalog.ala1.runs import ChannelRun, decide

#: ``FaultLog.report``: a channel's internal error at a host time.
Report = Callable[[int, Exception, float], None]

_ZERO = Decimal(0)
_NEVER = Decimal(-1)


def decide_series(
    run: ChannelRun, times: list[int], values: Column, offset: float, report: Report
) -> dict[int, str]:
    """:func:`runs.decide` of every sample of ``run`` at ``times``: the texts written, by
    instant (as :meth:`Sampler._measure_due` does sample by sample); faults are reported."""
    cfg = run.cfg
    try:
        if cfg.average > 0:
            written = _averaged_bulk(run, times, values, offset, report)
        else:
            written = _plain_bulk(run, times, values, offset, report)
    except Exception:  # (sample by sample: the failing one is that sample's fault)
        written = None
    if written is not None:
        return written
    if cfg.average > 0:
        return _averaged(run, times, values, offset, report)
    return _one_by_one(run, times, values, offset, report)


def record_all(run: ChannelRun, texts: Sequence[str]) -> list[tuple[int, str]]:
    """:func:`runs.record` of each of ``texts`` in order: the indexes and texts written. The
    run's state changes only at the end (nothing is written when anything raises)."""
    cfg = run.cfg
    change, samples = cfg.change, cfg.samples
    if not texts:
        return []
    if change == _ZERO:  # every text written
        run.recorded, run.since_write = texts[-1], 0
        return list(enumerate(texts))
    since = run.since_write
    out: list[tuple[int, str]] = []
    if change == _NEVER:  # only the samples condition writes
        if samples > 0:
            out = [(k, texts[k]) for k in range(max(0, samples - since - 1), len(texts), samples)]
        if out:
            run.recorded, run.since_write = out[-1][1], len(texts) - 1 - out[-1][0]
        else:
            run.since_write = since + len(texts)
        return out
    recorded, active = run.recorded, run.event_active
    events = cfg.type == 6
    decimals = cfg.format.decimals
    # |a - b| >= change for texts of ``decimals`` decimals: |A - B| >= least in their units
    least = _least(change, decimals)
    if not events and change > _ZERO and recorded:
        in_units = _units_all(texts, recorded, decimals)
        if in_units is not None:  # (every text a number of the channel's format)
            return _by_units(run, texts, in_units, least, samples)
    zero = format_value(cfg, 0.0) if events else ""
    same_writes = change <= _ZERO  # (runs._changed of two equal non-empty texts)
    numbers: dict[str, Decimal] = {}  # (Decimal(text) of the texts met, as runs.decimal_of)
    last: int | Decimal | None = None  # the recorded text in units, once needed
    units_of: dict[str, int | None] = {}  # (the texts compared in units: they repeat)
    n = len(texts)
    starts: Sequence[int]
    if len(set(texts)) * 4 < n:  # long runs of one text (events, a steady signal): each
        starts = [0, *(k for k in range(1, n) if texts[k] != texts[k - 1])]  # decided once
        ends: Sequence[int] = [*starts[1:], n]
    else:
        starts, ends = range(n), range(1, n + 1)
    for k, end in zip(starts, ends, strict=True):
        text = texts[k]
        since += 1
        write: str | None = None
        units: int | None = None  # (the text in units, when compared)
        if events:  # §6.5.16.1
            if text:
                x = numbers.get(text)
                if x is None:
                    x = numbers[text] = Decimal(text)
                if x >= change:
                    write, active = text, True
                elif active:
                    write, active = zero, False
            elif active:
                write, active = zero, False
        elif recorded is None:
            write = text
        elif text == recorded:
            if same_writes and text:
                write = text
        elif not text or not recorded:
            write = text
        else:  # |text - recorded| >= change, in units of the last decimal where it can
            if last is None:
                last = _units(recorded, decimals)
            if isinstance(last, int):
                units = units_of.get(text)
                if units is None:  # (a number of the channel's format: its digits)
                    units = units_of[text] = _unit_of(text, decimals)
            if units is not None and isinstance(last, int):
                if abs(units - last) >= least:
                    write = text
            elif abs(Decimal(text) - Decimal(recorded)) >= change:
                write = text
        if write is None and samples > 0 and since >= samples:
            write = text
        if write is not None:
            recorded, since = write, 0
            last = units if write is text else None
            out.append((k, write))
        if end - k > 1:  # the same text again up to ``end``
            if active if events else (same_writes and text and text == recorded):
                out += [(j, text) for j in range(k + 1, end)]  # each one written
                recorded, since, last = text, 0, None
            else:  # (no condition changes: only the samples condition writes)
                first = k + max(1, samples - since)
                if samples > 0 and first < end:
                    out += [(j, text) for j in range(first, end, samples)]
                    if recorded is not text:
                        recorded, last = text, None
                    since = end - 1 - out[-1][0]
                else:
                    since += end - k - 1
    run.recorded, run.since_write, run.event_active = recorded, since, active
    return out


@functools.lru_cache(maxsize=64)
def _least(change: Decimal, decimals: int) -> int:
    """The least difference of two texts of ``decimals`` decimals, in units of the last
    decimal, that makes a change of at least ``change``."""
    return int((change.scaleb(decimals)).to_integral_value(rounding=ROUND_CEILING))


@functools.lru_cache(maxsize=16)
def _format_of(decimals: int) -> re.Pattern[str]:
    """A text of the channel's format: a whole number, or ``decimals`` decimals."""
    return re.compile(rf" *-?[0-9]+\.[0-9]{{{decimals}}}" if decimals else " *-?[0-9]+")


def _units_all(texts: Sequence[str], recorded: str, decimals: int) -> list[int] | None:
    """Each of ``texts`` and ``recorded`` (the last) in units of the last decimal, when
    every one is a number of the channel's format (then ``int`` of its digits is the
    number :func:`_units` gives); else None. Texts met lately are looked up."""
    known = _KNOWN.get(decimals)
    if known is None:
        known = _KNOWN[decimals] = {}
    try:
        got = [*map(known.__getitem__, texts), known[recorded]]
    except KeyError:
        fits = _format_of(decimals).fullmatch
        new = {*texts, recorded}.difference(known)
        if len(known) + len(new) > _KNOWN_MAX:
            known.clear()
            new = {*texts, recorded}
        known.update((t, int(t.replace(".", "")) if fits(t) else None) for t in new)
        got = [*map(known.__getitem__, texts), known[recorded]]
    return None if has_none(got) else got  # type: ignore[return-value]


def _unit_of(text: str, decimals: int) -> int | None:
    """``text`` in units of the last decimal when it is a number of the channel's format
    (``int`` of its digits), else None."""
    return int(text.replace(".", "")) if _format_of(decimals).fullmatch(text) else None


#: Texts in units of the last decimal (None: not a number of the format), by decimals
#: (shared with :func:`format_values`, which adds the texts it renders by units).
_KNOWN = KNOWN_UNITS
_KNOWN_MAX = KNOWN_UNITS_MAX


def _by_units(
    run: ChannelRun, texts: Sequence[str], units: list[int], least: int, samples: int
) -> list[tuple[int, str]]:
    """:func:`record_all` of a channel whose texts are all numbers of its format and whose
    recorded text is one (``units``: the texts' units, then the recorded text's)."""
    last = units.pop()
    written = _written_by_units(units, last, least, samples, run.since_write)
    chosen = [texts[k] for k in written]
    _wrote(run, len(units), written, chosen)
    return list(zip(written, chosen, strict=True))


def _written_by_units(
    units: Sequence[float], last: float, least: int, samples: int, since: int
) -> list[int]:
    """The indexes of the texts written, of texts whose units are ``units`` after a
    recorded text of ``last`` units: a text is written when it differs from the recorded
    one by ``least`` units or more (§6.5.16.2), or when ``samples`` samples have passed
    since the last write (§6.5.16.3)."""
    n = len(units)
    # (a text is written when it leaves the band lo < u < hi around the recorded one, or at
    # the index ``due`` where ``samples`` samples have passed since the last write)
    lo, hi = last - least, last + least
    due = samples - since - 1 if samples > 0 else n
    if n and lo < (low := min(units)) and (high := max(units)) < hi and high - low < least:
        # a steady series (issue 24, seventh round): every value within the band, and in
        # the band of every other (each write by the samples condition moves it): only the
        # samples condition writes
        return list(range(max(0, due), n, samples)) if samples > 0 else []
    out: list[int] = []
    for k, u in enumerate(units):
        if not lo < u < hi or k >= due:
            out.append(k)
            lo, hi = u - least, u + least
            if samples > 0:
                due = k + samples
    return out


def _wrote(run: ChannelRun, n: int, written: list[int], texts: list[str]) -> None:
    """The run's state after ``n`` texts of which those at ``written`` (``texts``) were."""
    if written:
        run.recorded = texts[-1]
        run.since_write = n - 1 - written[-1]
    else:
        run.since_write += n


def record_values(
    run: ChannelRun, values: Sequence[float | None], fresh: bool = False
) -> list[tuple[int, str]]:
    """:func:`record_all` of ``format_values(run.cfg, values, fresh)``, the texts rendered
    only where written (issue 24, seventh round: most samples are not) when the change
    condition can be decided on the values' units of the last decimal: a channel of values
    (not events, §6.5.16.1) with a change above zero, a recorded text of its format, and
    every value rendered by its units (:func:`value_units`) or to a number of the format."""
    cfg = run.cfg
    recorded = run.recorded
    if cfg.type == 6 or not cfg.change > _ZERO or not recorded or not values:
        return record_all(run, format_values(cfg, values, fresh))
    if not fresh and (lately := rendered_lately(cfg, values)) is not None:
        try:  # (values met lately, a steady input: looked up in C, cheaper than units)
            "".join(lately)  # type: ignore[arg-type]  # (a None raises, in one C loop)
        except TypeError:
            pass
        else:
            return record_all(run, lately)  # type: ignore[arg-type]
    decimals = cfg.format.decimals
    units = value_units(decimals, values)
    last = _unit_of(recorded, decimals)
    if last is None:
        return record_all(run, format_values(cfg, values, fresh))
    if has_none(units):  # (a value far out or near a half, or none: by its text)
        if units.count(None) * 8 > len(units):  # (many: as many texts rendered anyway)
            return record_all(run, format_values(cfg, values, fresh))
        for k, u in enumerate(units):
            if u is None:
                text = format_value(cfg, values[k])
                units[k] = unit = _unit_of(text, decimals) if text else None
                if unit is None:  # (no value, or not a number of the format)
                    return record_all(run, format_values(cfg, values, fresh))
    least = _least(cfg.change, decimals)
    written = _written_by_units(units, last, least, cfg.samples, run.since_write)  # type: ignore[arg-type]  # (no None left)
    # (the text of the units written: a text of the format is the one of its units)
    texts = list(map(texts_by_units(cfg).get, [units[k] for k in written]))  # type: ignore[arg-type]
    if None in texts:  # (units not rendered lately: rendered by their values)
        missing = [k for k, text in zip(written, texts, strict=True) if text is None]
        rendered = iter(format_values(cfg, [values[k] for k in missing], fresh))
        texts = [next(rendered) if text is None else text for text in texts]
    _wrote(run, len(units), written, texts)  # type: ignore[arg-type]
    return list(zip(written, texts, strict=True))  # type: ignore[arg-type]


def _units(text: str, decimals: int) -> int | Decimal:
    """The number ``text`` shows in units of ``10**-decimals``: an int when it is whole (a
    text of the channel's format), else the Decimal."""
    scaled = Decimal(text).scaleb(decimals)
    return int(scaled) if scaled == scaled.to_integral_value() else scaled


def _plain_bulk(
    run: ChannelRun, times: list[int], values: Column, offset: float, report: Report
) -> dict[int, str]:
    """A channel without averaging: a sample without a valid value (a fault too) is the
    empty text, as :func:`runs.decide` formats it."""
    cfg = run.cfg
    written = record_values(run, values.values)  # (a fault's value is None: "")
    for k, exc in sorted(values.faults.items()):
        report(cfg.number, exc, times[k] - offset)
    run.sample, run.sampled = values.values[-1], True
    return {times[k]: text for k, text in written}


def _valid(samples: list[Value]) -> tuple[list[int] | None, list[Value]]:
    """The positions of the samples with a valid value (None: every one), and those values
    (an average counts only them, §6.5.15)."""
    if has_none(samples):
        index = [k for k, value in enumerate(samples) if value is not None]
        return index, [samples[k] for k in index]
    return None, samples


def _reduced(values: Iterable[Value], start: float) -> float:
    """``((start + v0) + v1) + ...``: the sum as the event-by-event path adds it."""
    return functools.reduce(operator.add, values, start)


#: :func:`_reduced`, by the C loop of ``sum`` where it adds floats in that very order
#: (Python 3.12 sums floats with compensation: there ``functools.reduce``).
_sum: Callable[[Iterable[Value], float], float]
if sys.version_info < (3, 12):
    _sum = sum  # type: ignore[assignment]
else:
    _sum = _reduced


def _averaged_bulk(
    run: ChannelRun, times: list[int], values: Column, offset: float, report: Report
) -> dict[int, str] | None:
    """:func:`_averaged` at once: each average ``(((s + v0) + v1) + ...) / n`` as
    :func:`runs.decide` sums it (``s`` the run's partial sum for the first, 0.0 after)."""
    cfg = run.cfg
    n, have, partial = cfg.average, run.avg_n, run.avg_sum
    need = n - have
    if need < 1:
        return None
    samples = values.values
    index, valid = _valid(samples)
    add, reduce = operator.add, functools.reduce
    averages: list[float] = []
    if len(valid) >= need:
        averages.append(_sum(valid[:need], partial) / n)
        rest = iter(valid[need:])  # (the next averages: zip takes n samples at a time)
        groups = zip(*[rest] * n, strict=False)  # (an incomplete last group is left off)
        averages += map(operator.truediv, map(_sum, groups, repeat(0.0)), repeat(n))
        used = need + (len(averages) - 1) * n
        partial, have = reduce(add, valid[used:], 0.0), len(valid) - used
    else:
        partial, have = reduce(add, valid, partial), have + len(valid)
    written = record_values(run, averages, fresh=True)
    run.avg_sum, run.avg_n = partial, have
    for k, exc in values.faults.items():
        report(cfg.number, exc, times[k] - offset)
    run.sample, run.sampled = samples[-1], True
    if index is None:
        return {times[need - 1 + m * n]: text for m, text in written}
    return {times[index[need - 1 + m * n]]: text for m, text in written}


def _one_by_one(
    run: ChannelRun, times: list[int], values: Column, offset: float, report: Report
) -> dict[int, str]:
    """:func:`decide_series` of a channel without averaging, sample by sample."""
    cfg = run.cfg
    faults = values.faults
    written: dict[int, str] = {}
    sample: Value = None
    for k, value in enumerate(values.values):
        sample = value
        if faults and k in faults:
            # (Sampler._measure_due's except branch)
            report(cfg.number, faults[k], times[k] - offset)
            try:
                text = decide(run, None)
            except Exception:
                text = None
        else:
            text, failed = _decide_reporting(run, value, report, times[k] - offset)
            if failed:
                sample = None
        if text is not None:
            written[times[k]] = text
    run.sample, run.sampled = sample, True
    return written


def _decide_reporting(
    run: ChannelRun, value: Value, report: Report, when: float
) -> tuple[str | None, bool]:
    """:func:`decide` of ``value``; when it raises, the fault reported at module time ``when``
    and the sample decided as one without a valid value (Sampler._measure_due's except
    branch): ``(text, failed)``."""
    try:
        return decide(run, value), False
    except Exception as exc:
        report(run.cfg.number, exc, when)
    try:
        return decide(run, None), True
    except Exception:
        return None, True


def _averaged(
    run: ChannelRun, times: list[int], values: Column, offset: float, report: Report
) -> dict[int, str]:
    """:func:`decide_series` of an averaging channel (§6.5.15), one average after the other:
    a sample without a valid value does not count, and :func:`decide` of one is a no-op; the
    samples of each average are summed in order as the event-by-event path adds them, then
    :func:`decide` adds the last one and decides on the average."""
    cfg = run.cfg
    for k, exc in values.faults.items():
        report(cfg.number, exc, times[k] - offset)
    samples = values.values
    index, valid = _valid(samples)
    if index is None:
        index = list(range(len(samples)))
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
        text, failed = _decide_reporting(run, valid[i + need - 1], report, times[k] - offset)
        if failed and k == last:
            sample = None
        if text is not None:
            written[times[k]] = text
        i += need
    run.avg_sum = functools.reduce(operator.add, valid[i:], run.avg_sum)
    run.avg_n += len(valid) - i
    run.sample, run.sampled = sample, True
    return written
