"""Record conditions over a series of texts (issue 24, ``conditions.record_all``) against
:func:`runs.record` text by text (§6.5.16): the very rows written and the very state after
them, for change conditions of any size (in units of the last decimal or not), the samples
condition, events (type 6), empty texts, texts of another format, runs of one text; and
``conditions.record_values`` (the texts rendered only where written) against both."""

from __future__ import annotations

import math
from dataclasses import replace
from decimal import ROUND_CEILING, Decimal

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.ala1 import measure
from sondalog.ala1.conditions import record_all, record_values
from sondalog.ala1.measure import ChannelConfig, Input, format_value, format_values
from sondalog.ala1.runs import ChannelRun, record
from sondalog.ala1.tokens import NumberFormat

NOTHING = Input(0, 0, "", 0, 1.0, 0.0, 1.0, 0.0, 0, 0)


def _config(kind: int, decimals: int, change: str, samples: int) -> ChannelConfig:
    return ChannelConfig(
        1, kind, (NOTHING, NOTHING), "", "", 1.0, 0.0, NumberFormat(6, decimals), 60, "", 0,
        Decimal(change), samples,
    )  # fmt: skip


def _state(run: ChannelRun) -> tuple[str | None, int, bool]:
    """What a run carries from one sample to the next: the last written text, the samples
    since it, and the event's state (the conditions of §6.5.16)."""
    return (run.recorded, run.since_write, run.event_active)


@st.composite
def texts(draw: st.DrawFn, decimals: int) -> list[str]:
    """A walk of values shown in the format (repeats and runs), some empty, a few of
    another format."""
    units = draw(st.lists(st.integers(-30, 30), max_size=80))
    level, out = 0, []
    for step in units:
        level += 0 if abs(step) < 15 else step // 10 if abs(step) < 27 else step  # (runs)
        value = Decimal(level).scaleb(-decimals)
        out.append(f"{value:.{decimals}f}".rjust(6))
    for k in draw(st.lists(st.integers(0, 79), max_size=3)):
        if k < len(out):
            out[k] = draw(st.sampled_from(["", "12.5", " -0.0", "7"]))
    return out


@settings(max_examples=300)  # (fast: worth more examples)
@given(
    data=st.data(),
    decimals=st.integers(0, 3),
    kind=st.sampled_from([3, 3, 6]),
    change=st.sampled_from(["0", "-1", "0.001", "0.01", "0.05", "0.5", "2", "0.015"]),
    samples=st.sampled_from([0, 0, 1, 3, 10]),
    recorded=st.one_of(
        st.sampled_from([None, "", "  0.00", " 1.5", "3"]), st.integers(-20, 20), st.integers(-3, 3)
    ),
    since=st.integers(0, 12),
    active=st.booleans(),
)
def test_record_all_is_record_text_by_text(
    data: st.DataObject,
    decimals: int,
    kind: int,
    change: str,
    samples: int,
    recorded: str | int | None,
    since: int,
    active: bool,
) -> None:
    cfg = _config(kind, decimals, change, samples)
    if isinstance(recorded, int):  # (a text of the channel's format, mostly)
        recorded = f"{Decimal(recorded).scaleb(-decimals):.{decimals}f}".rjust(6)
    series = data.draw(texts(decimals))
    one = ChannelRun(cfg, recorded=recorded, since_write=since, event_active=active)
    many = replace(one)
    expected = [(k, w) for k, text in enumerate(series) if (w := record(one, text)) is not None]
    assert record_all(many, series) == expected
    assert _state(many) == _state(one)


@settings(max_examples=300)
@given(
    moves=st.lists(
        st.tuples(st.integers(1, 120), st.integers(-40, 40)), min_size=1, max_size=12
    ),  # (long runs of a slow signal, then a move)
    decimals=st.integers(0, 3),
    change=st.sampled_from(["0.001", "0.01", "0.05", "0.5", "2", "0.015"]),
    samples=st.sampled_from([0, 1, 7, 9, 10, 60, 200]),
    recorded=st.integers(-20, 20),
    since=st.integers(0, 250),
    drift=st.integers(0, 3),
)
def test_slow_signals_write_as_text_by_text(
    moves: list[tuple[int, int]],
    decimals: int,
    change: str,
    samples: int,
    recorded: int,
    since: int,
    drift: int,
) -> None:
    """A steady or slowly drifting signal (issue 24, fifth round: the next write searched
    in C past the first few texts): long stretches without a write, the samples condition
    falling before, on and after a change, a ``since`` beyond ``samples``."""
    cfg = _config(3, decimals, change, samples)
    level, units = recorded, []
    for length, move in moves:
        for k in range(length):
            units.append(level + (k * drift) // 16)  # (a slow drift, in steps of one unit)
        level += move
    series = [f"{Decimal(u).scaleb(-decimals):.{decimals}f}".rjust(6) for u in units]
    first = f"{Decimal(recorded).scaleb(-decimals):.{decimals}f}".rjust(6)
    one = ChannelRun(cfg, recorded=first, since_write=since)
    many = replace(one)
    expected = [(k, w) for k, text in enumerate(series) if (w := record(one, text)) is not None]
    assert record_all(many, series) == expected
    assert _state(many) == _state(one)


@st.composite
def values(draw: st.DrawFn, decimals: int, start: float) -> list[float | None]:
    """A walk of values from near ``start`` in steps about the change condition's, with
    values near a half of the last decimal, near zero, beyond 2**33 units, negative, and
    without a value (None, NaN)."""
    scale = 10.0**-decimals
    level, out = start + draw(st.floats(-3, 3)) * draw(st.sampled_from([scale, 0.01, 1.0])), []
    for step in draw(st.lists(st.floats(-3, 3), max_size=60)):
        level += step * draw(st.sampled_from([0.0, scale, 0.1, 1.0]))
        out.append(level)
    odd = st.one_of(
        st.integers(-999, 999).map(lambda k: (k + 0.5) * scale),  # (a half: rounded exactly)
        st.integers(-999, 999).map(lambda k: (k + 0.5) * scale + 1e-12),
        st.floats(-2e-4, 2e-4),
        st.sampled_from([None, math.nan, math.inf, 0.0, -0.0, 2.0**33 * scale, -1e15]),
        st.floats(allow_nan=False, allow_infinity=False),
    )
    for k in draw(st.lists(st.integers(0, 59), max_size=4)):
        if k < len(out):
            out[k] = draw(odd)
    return out


@settings(max_examples=400)
@given(
    data=st.data(),
    decimals=st.integers(0, 3),
    width=st.sampled_from([0, 6, 9]),
    kind=st.sampled_from([3, 3, 3, 6]),
    change=st.sampled_from(["0", "-1", "0.001", "0.01", "0.05", "0.5", "2", "0.015"]),
    samples=st.sampled_from([0, 0, 1, 3, 10]),
    recorded=st.one_of(
        st.sampled_from([None, "", "  0.00", " 1.5", "3", "-0.5", "12.345"]),
        st.integers(-5000, 5000),
    ),
    since=st.integers(0, 12),
    fresh=st.booleans(),
    warm=st.booleans(),
)
def test_record_values_writes_as_each_value_text_by_text(
    data: st.DataObject,
    decimals: int,
    width: int,
    kind: int,
    change: str,
    samples: int,
    recorded: str | int | None,
    since: int,
    fresh: bool,
    warm: bool,
) -> None:
    """``record_values`` (issue 24, seventh round: the texts rendered only where written)
    against :func:`runs.record` of every value's text: the very rows and state after them
    (``warm``: every value rendered before, by the value and by its units, as a steady
    input's are; else none)."""
    cfg = replace(_config(kind, decimals, change, samples), format=NumberFormat(width, decimals))
    start = data.draw(st.floats(-50, 50))
    if isinstance(recorded, int):  # (a text of the channel's format, mostly; values near it)
        start = recorded * 10.0**-decimals
        recorded = f"{Decimal(recorded).scaleb(-decimals):.{decimals}f}".rjust(width)
    series = data.draw(values(decimals, start))
    one = ChannelRun(cfg, recorded=recorded, since_write=since)
    many = replace(one)
    texts = [format_value(cfg, value) for value in series]  # (every value, one by one)
    if warm:
        format_values(cfg, series, fresh=True)  # (their texts by units too)
    else:
        measure._RENDERED.clear()
        measure._BY_UNITS.clear()
    expected = [(k, w) for k, text in enumerate(texts) if (w := record(one, text)) is not None]
    assert record_values(many, series, fresh) == expected
    assert _state(many) == _state(one)


@settings(max_examples=300)
@given(
    decimals=st.integers(0, 3),
    change=st.sampled_from(["0.001", "0.01", "0.05", "0.5", "2", "0.015"]),
    samples=st.sampled_from([0, 1, 3, 10, 60]),
    since=st.integers(0, 70),
    recorded=st.integers(-20, 20),
    shift=st.integers(-3, 3),
    gap=st.integers(-1, 1),
    levels=st.lists(st.booleans(), min_size=1, max_size=80),
)
def test_steady_series_write_as_text_by_text(
    decimals: int,
    change: str,
    samples: int,
    since: int,
    recorded: int,
    shift: int,
    gap: int,
    levels: list[bool],
) -> None:
    """Two levels ``least - 1``, ``least`` or ``least + 1`` units apart, near the recorded
    text (issue 24, seventh round: a series within the band of each of its values writes
    only by the samples condition): the very rows and state as text by text."""
    cfg = _config(3, decimals, change, samples)
    least = int(Decimal(change).scaleb(decimals).to_integral_value(rounding=ROUND_CEILING))
    low = recorded + shift * least // 3
    units = [low + (least + gap) * high for high in levels]
    series = [f"{Decimal(u).scaleb(-decimals):.{decimals}f}".rjust(6) for u in units]
    first = f"{Decimal(recorded).scaleb(-decimals):.{decimals}f}".rjust(6)
    one = ChannelRun(cfg, recorded=first, since_write=since)
    many = replace(one)
    expected = [(k, w) for k, text in enumerate(series) if (w := record(one, text)) is not None]
    assert record_all(many, series) == expected
    assert _state(many) == _state(one)
