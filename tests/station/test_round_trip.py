"""Round trip on virtual loggers of both protocol versions (issue 22): pull from a logger
configured by hand, apply to a factory-fresh logger, pull again: identical files and identical
answers to every ``read`` of the parameter tree, over random valid configurations."""

from __future__ import annotations

import asyncio
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from setting_values import values
from station_helpers import ask, every_read, explain_text, served

from sondalog.client.station_apply import apply, make_plan, pull
from sondalog.client.station_file import read_station
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_schema import SETTINGS
from sondalog.config import loads

#: Left to its own test: once set, every line needs iaddress.
_RANDOM = [s for s in SETTINGS if s.pattern != "i address"]
_TEXT = "abcXYZ019 -_.,:/*#"


@st.composite
def writes(draw: st.DrawFn, version: str) -> list[str]:
    """Hand-typed writes of valid values (the logger may still refuse some: state)."""
    limits = LIMITS[version]
    out = []
    for _ in range(draw(st.integers(1, 25))):
        setting = draw(st.sampled_from(_RANDOM))
        n = draw(st.integers(1, setting.count(limits)))
        text = draw(_value(setting, limits))
        try:
            value = setting.grammar.check(text, limits)
        except ValueError:
            continue
        if setting.dual:
            value = f"{value},{draw(_value(setting, limits).filter(_valid(setting, limits)))}"
            value = ",".join(setting.grammar.check(p, limits) for p in value.split(","))
        dual = " all" if setting.dual else ""
        out.append(f"write {setting.name(n)}{dual}{setting.grammar.written(value)}")
    return out


def _valid(setting, limits):  # type: ignore[no-untyped-def]
    def ok(text: str) -> bool:
        try:
            setting.grammar.check(text, limits)
        except ValueError:
            return False
        return True

    return ok


def _value(setting, limits) -> st.SearchStrategy[str]:  # type: ignore[no-untyped-def]
    return values(
        setting,
        limits,
        number=st.decimals(-999, 999, places=3).map(lambda d: format(abs(d), "f")),
        text=lambda longest: st.text(_TEXT, max_size=longest or 30),
    )


async def _round_trip(tmp: Path, version: str, hand: list[str]) -> None:
    async with served(tmp / "a", version) as a, served(tmp / "b", version) as b:
        await ask(a.url, hand)
        text, _ = await pull(a.url)
        station = read_station(loads(text))
        outcome = await apply(b.url, station, explain_text)
        assert outcome.error is None, outcome.error
        again, _ = await pull(b.url)
        assert again == text
        assert await every_read(b.url, version) == await every_read(a.url, version)
        assert (await pull(b.url, all_values=True))[0] == (await pull(a.url, all_values=True))[0]
        assert (await make_plan(b.url, station)).empty  # applying again changes nothing
        assert (await apply(b.url, station, explain_text)).applied == []


@pytest.mark.parametrize("version", ["2.10", "1.16"])
def test_round_trip_property(version: str) -> None:
    @settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
    @given(hand=writes(version))
    def check(hand: list[str]) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            asyncio.run(_round_trip(Path(tmp), version, hand))

    check()
