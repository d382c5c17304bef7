"""``examples/station.toml`` is the configuration of the demo's field logger (issue 22)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from station_helpers import ask, explain_text, served

from sondalog.app.demo_world import RAIN
from sondalog.client.station_apply import apply, make_plan, pull
from sondalog.client.station_fleet import read_file

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "station.toml"


def test_the_example_is_the_demo_field_logger(tmp_path: Path) -> None:
    (target,) = read_file(EXAMPLE)

    async def run() -> None:
        async with served(tmp_path / "demo", "2.10", RAIN.serial) as demo:
            assert set(await ask(demo.url, list(RAIN.settings))) == {"OK"}
            assert (await make_plan(demo.url, target.station)).empty
            text, _ = await pull(demo.url)
            assert EXAMPLE.read_text().endswith(text)
        async with served(tmp_path / "fresh", "2.10", RAIN.serial) as fresh:
            assert (await apply(fresh.url, target.station, explain_text)).error is None
            assert (await pull(fresh.url))[0] == text

    asyncio.run(run())
