"""The record's row time worked out a day at a time (moduleclock.stamp, issue 24) is the
text the clock's datetime gives, over the whole calendar and past either end."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.moduleclock import CLOCK_MAX, CLOCK_MIN, from_seconds, stamp
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
