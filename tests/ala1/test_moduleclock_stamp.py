"""The record's row time worked out a day at a time (moduleclock.stamp, issue 24) is the
text the clock's datetime gives, over the whole calendar and past either end; a stretch's
(moduleclock.stamps) is each one's."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.moduleclock import CLOCK_MAX, CLOCK_MIN, from_seconds, stamp, stamps
from sondalog.ala1.tokens import format_stamp


@given(st.integers(CLOCK_MIN - 10**7, CLOCK_MAX + 10**7))
def test_stamp_is_the_datetimes_text(seconds: int) -> None:
    assert stamp(seconds) == format_stamp(from_seconds(seconds))


@given(st.floats(CLOCK_MIN, CLOCK_MAX, allow_nan=False))
def test_stamp_of_a_fraction_is_its_whole_second(seconds: float) -> None:
    assert stamp(seconds) == format_stamp(from_seconds(seconds))


def test_the_calendars_ends_and_a_leap_day() -> None:
    assert stamp(CLOCK_MIN) == "00010101000000"
    assert stamp(CLOCK_MAX + 1) == "99991231235959"
    assert stamp(951_782_400 + 86_399) == "20000229235959"
    assert stamp(-1) == "19691231235959"


@given(
    st.sampled_from([CLOCK_MIN, 0, 1_167_609_600, CLOCK_MAX]).map(int),
    st.lists(st.integers(-200_000, 200_000), max_size=60),
)
def test_stamps_of_a_stretch_are_each_ones_stamp(around: int, shifts: list[int]) -> None:
    """Ascending seconds over days and past the calendar's ends (held there)."""
    seconds = sorted({around + shift for shift in shifts})
    assert stamps(seconds) == [stamp(s) for s in seconds]
