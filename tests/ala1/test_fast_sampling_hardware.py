"""The simulation's inputs read as columns (issue 24, ``SimHardware.adc_column``,
``ds18b20_column``, ``supply_column``) against its reads instant by instant: the very floats
(a -0.0 told from a 0.0), a device calibration applied to each reading, for signals within
the input's range (the shortcut that rounds them alone), beyond it at either end (held at the
ends), steady ones, and a NaN (an ADC's raises as its one-time read does; a supply's and a
DS18B20's read as the held value)."""

from __future__ import annotations

import math

from hypothesis import example, given
from hypothesis import strategies as st

from sondalog.ala1.rendering import HALF_EVEN
from sondalog.backends.sim.logger import Analog, SimHardware, Thermometer

ROM = 0x2800000000000A28
#: Signal values: volts about an ADC's range, a supply's, temperatures, and the odd ones.
LEVELS = st.one_of(
    st.floats(-1.0, 3.0),
    st.floats(-5.0, 40.0),
    st.floats(-80.0, 150.0),
    st.sampled_from([0.0, -0.0, 2.5, 27.5, -55.0, 125.0, math.nan, math.inf, 1e300]),
)
CALIBRATIONS = st.sampled_from([(1.0, 0.0), (1.0, 0.0), (-2.5, 0.0), (1000.0, 0.25), (1.0, -0.5)])


class Series:
    """A signal whose value at second ``t`` is ``values[int(t)]`` (read time by time)."""

    def __init__(self, values: list[float]) -> None:
        self.values = values

    def __call__(self, t: float) -> float:
        return self.values[int(t)]


def _same(column: list[float | None], expected: list[float | None]) -> bool:
    return [repr(v) for v in column] == [repr(v) for v in expected]


def _hardware(values: list[float]) -> SimHardware:
    signal = Series(values)
    return SimHardware(
        supply=signal,
        supply_power=None,  # (always on)
        analog=[Analog(16, signal)],
        thermometers=[Thermometer(4, ROM, signal)],
    )


@given(
    st.one_of(
        st.lists(LEVELS, min_size=1, max_size=40),
        st.tuples(LEVELS, st.integers(1, 40)).map(lambda vn: [vn[0]] * vn[1]),  # steady
    ),
    CALIBRATIONS,
)
@example([0.5, 1.2, 2.4], (1.0, 0.0))  # (within every range)
@example([20.5, 21.0], (1.0, 0.0))
@example([20.5, math.nan], (1.0, 0.0))  # (a NaN after a value: min() and max() miss it)
@example([0.5, math.nan, 1.0], (1.0, 0.0))  # (the same within an ADC's range)
@example([1.0, 125.0], (1.0, 0.0))
def test_columns_are_the_reads_instant_by_instant(
    values: list[float], calibration: tuple[float, float]
) -> None:
    mult, add = calibration
    sim = _hardware(values)
    times = [float(t) for t in range(len(values))]
    try:
        adc = [r * mult + add for r in (sim.adc(1, 16, t) for t in times) if r is not None]
    except ValueError:  # (a NaN: the column raises too)
        adc = None
    if adc is None:
        try:
            sim.adc_column(1, 16, times, mult, add)
        except ValueError:
            pass
        else:
            raise AssertionError("adc_column read a NaN")
    else:
        assert _same(sim.adc_column(1, 16, times, mult, add), adc)
    thermometer = [sim.ds18b20(4, ROM, t) for t in times]
    expected = [None if r is None else r[1] * mult + add for r in thermometer]
    assert _same(sim.ds18b20_column(4, ROM, times, mult, add), expected)
    supply = [sim.supply(t) for t in times]
    expected = [None if r is None else (r * mult + add) * 11.0 for r in supply]
    assert _same(sim.supply_column(times, mult, add, 11.0), expected)


@given(
    st.one_of(
        st.floats(-(2.0**51), 2.0**51, exclude_max=True, exclude_min=True),
        st.integers(-(2**20), 2**20).map(lambda n: n / 2),  # (the ties: every .5)
        st.integers(-(2**50), 2**50).map(float),
    )
)
def test_adding_and_taking_half_even_is_round(y: float) -> None:
    """The columns' and format_values' rounding (``rendering.HALF_EVEN``): ``y + M - M`` is
    ``round(y)`` as a float, ties to the even, a -0.0 and a value rounded to zero alike
    (+0.0)."""
    m = HALF_EVEN
    assert repr(y + m - m) == repr(float(round(y)))
