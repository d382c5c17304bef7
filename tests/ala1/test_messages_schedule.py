"""The period of a message (§6.14.4, §6.14.5), month rule included: pure schedule tests."""

from __future__ import annotations

from datetime import datetime

from sondalog.ala1.messages.schedule import add_months, next_due
from sondalog.ala1.moduleclock import from_seconds, to_seconds


def at(text: str) -> float:
    return to_seconds(datetime.strptime(text, "%Y%m%d%H%M%S"))


def due(period: str, start: str, now: str) -> str | None:
    t = next_due(period, at(start), at(now))
    return None if t is None else from_seconds(t).strftime("%Y%m%d%H%M%S")


def test_a_future_start_is_the_first_sending() -> None:
    assert due("240000", "20070302000000", "20070301120000") == "20070302000000"


def test_a_past_start_moves_forward_by_whole_periods() -> None:
    assert due("001000", "20070301084500", "20070301085959") == "20070301090500"
    assert due("001000", "20070301084500", "20070301090500") == "20070301090500"
    assert due("990102", "20070101000000", "20070102000001") == "20070102020000"


def test_period_zero_is_off() -> None:
    assert due("000000", "20070101000000", "20070101000000") is None


def test_month_period_falls_on_the_last_day_of_a_shorter_month() -> None:
    start = "20070131120000"
    assert due("999901", start, "20070131120001") == "20070228120000"
    assert due("999901", start, "20070228120001") == "20070331120000"  # back to the 31st
    assert due("999901", start, "20070331120001") == "20070430120000"
    assert due("999901", "20080130060000", "20080131000000") == "20080229060000"  # leap year
    assert due("999901", "20071231000000", "20080115000000") == "20080131000000"


def test_add_months_clamps_the_day() -> None:
    assert add_months(datetime(2007, 1, 31), 1) == datetime(2007, 2, 28)
    assert add_months(datetime(2007, 1, 31), 13) == datetime(2008, 2, 29)
    assert add_months(datetime(2007, 11, 30), 3) == datetime(2008, 2, 29)


def test_month_period_at_the_end_of_the_calendar() -> None:
    assert due("999901", "99991231000000", "99991231000001") is None
