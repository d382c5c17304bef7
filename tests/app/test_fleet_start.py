"""Starting a fleet (issue 24): identities read or written in threads, each logger's error
still named by its entry."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest

from sondalog.app.fleet import start_fleet
from sondalog.app.fleet_site import FleetLogger
from sondalog.config import ConfigError
from sondalog.io.clock import SteppedClock


def _fleet(count: int, protocol: str | None = None) -> list[FleetLogger]:
    return [
        FleetLogger(f"S{n:03}", ("127.0.0.1", 0), protocol, where=f"loggers[{n % 2}]")
        for n in range(count)
    ]


def test_a_new_fleet_writes_every_identity_and_a_restart_reads_them(tmp_path: Path) -> None:
    async def start(loggers: list[FleetLogger]) -> list[str]:
        fleet = await start_fleet(loggers, tmp_path, SteppedClock(), None)
        try:
            return [m.engine.identity.version.value for m in fleet.members]
        finally:
            await fleet.close()

    assert asyncio.run(start(_fleet(40, "1.16"))) == ["1.16"] * 40
    for n in range(40):
        path = tmp_path / "loggers" / f"S{n:03}" / "identity.json"
        assert json.loads(path.read_text()) == {"protocol": "1.16", "serial_number": f"S{n:03}"}
        assert path.stat().st_mode & 0o777 == 0o600
    assert asyncio.run(start(_fleet(40))) == ["1.16"] * 40  # protocol from the state


def test_a_logger_whose_state_holds_another_protocol_is_named(tmp_path: Path) -> None:
    asyncio.run(_start_and_close(_fleet(4, "2.10"), tmp_path))
    (tmp_path / "loggers" / "S003" / "identity.json").write_text(
        json.dumps({"protocol": "1.16", "serial_number": "S003"})
    )
    with pytest.raises(ConfigError) as caught:
        asyncio.run(_start_and_close(_fleet(6, "2.10"), tmp_path))
    assert caught.value.field == "loggers[1].protocol"
    assert "holds a protocol 1.16 logger" in str(caught.value)


async def _start_and_close(loggers: list[FleetLogger], state: Path) -> None:
    fleet = await start_fleet(loggers, state, SteppedClock(), None)
    await fleet.close()
