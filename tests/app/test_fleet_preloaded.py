"""A fleet's loggers started from their memory read at once (issue 24: ``start_fleet`` builds
its engines inside ``NvDatabase.preloaded``, the start's commits in one batch) answer byte for
byte as engines built alone on a copy of the same database, one query at a time: random
lines of reads and writes over records of several pages, table files, repaired values."""

from __future__ import annotations

import asyncio
import random
import shutil
from pathlib import Path

import pytest

from sondalog.ala1 import Engine, Identity, Version
from sondalog.app.fleet import DATABASE_FILE, start_fleet
from sondalog.app.fleet_site import FleetLogger
from sondalog.app.logger import sensor_root
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.io.clock import SteppedClock

T0 = 1_000_000_000.0
SETUPS = (
    "write channel max number 3 write output 1 value 1 write channel type 1 1 1 "
    "write channel switch output 0 0 0",
    "write channel sampling period 000010 000010 000010",
    "write channel sampling start 20000101000000 20000101000000 20000101000000",
    "write channel 1 name /north/",
    "write message 1 period 000100",
)
LINES = (
    "read record status",
    "read record 1000000 from start",
    "read record 9 from start",
    "read record 3 from last",
    "read record 40 from lastread shift",
    "read record last read",
    "read date",
    "read channel 1 name",
    "read channel sampling period",
    "read i description",
    "read record type",
    "read message 1 period",
    "write channel 2 name /south/",
    "write record clear",
    "read channel 2 cal mult value",
)


def _ask(engine: Engine, line: int, text: str, now: float) -> bytes:
    return b"".join(o.data for o in engine.receive(line, text.encode() + b"\r", now))


def _fill(path: Path, serials: list[str], rng: random.Random) -> None:
    """Loggers configured in different ways, each sampled for a while (some records span
    several pages); one with a stored value that cannot be used."""
    database = NvDatabase(path)
    now = T0
    engines = []
    for serial in serials:
        engine = Engine(Identity(Version.V2_10, serial), database.store(serial), now)
        line = engine.open_line()
        for setup in SETUPS[: rng.randrange(len(SETUPS) + 1)]:
            assert _ask(engine, line, setup, now).endswith(b"OK\r\n"), setup
        engines.append(engine)
    for _ in range(rng.randrange(200, 400)):
        now += 10.0
        for engine in engines:
            engine.advance(now)
    database.store(serials[0]).write_file("list", b"")
    database.write([(serials[-1], ({"channel 2 record change": "x"}, None, None, None))])
    database.close()


@pytest.mark.parametrize("seed", range(3))
def test_a_preloaded_fleet_answers_as_engines_built_alone(tmp_path: Path, seed: int) -> None:
    rng = random.Random(seed)
    serials = [f"P{n}" for n in range(5)]
    state = tmp_path / "state"
    (state / "loggers").mkdir(parents=True)
    _fill(state / "loggers" / DATABASE_FILE, serials, rng)
    alone_path = tmp_path / "alone.sqlite"
    shutil.copy(state / "loggers" / DATABASE_FILE, alone_path)
    start = T0 + 5000.0
    lines = [(n, "read record 1000000 from start") for n in range(len(serials))]
    lines += [(rng.randrange(len(serials)), rng.choice(LINES)) for _ in range(60)]
    plan = FleetLogger(serials[0], ("127.0.0.1", 0))  # (the same simulated hardware)

    async def fleet_answers() -> list[bytes]:
        loggers = [FleetLogger(serial, ("127.0.0.1", 0)) for serial in serials]
        fleet = await start_fleet(loggers, state, SteppedClock(start), None)
        try:
            engines = [member.engine for member in fleet.members]
            for engine in engines:
                engine.advance(start)  # (what its host did at start, if it did)
            opened = [engine.open_line() for engine in engines]
            return [_ask(engines[n], opened[n], text, start) for n, text in lines]
        finally:
            await fleet.close()

    database = NvDatabase(alone_path)
    engines = [
        Engine(
            Identity(Version.V2_10, s),
            database.store(s),
            start,
            plan.hardware.build(start, sensor_root(), 1.0),
        )
        for s in serials
    ]
    for engine in engines:
        engine.advance(start)
    opened = [engine.open_line() for engine in engines]
    alone = [_ask(engines[n], opened[n], text, start) for n, text in lines]
    database.close()
    assert asyncio.run(fleet_answers()) == alone
    assert any(len(answer) > 2 * 64 * 20 for answer in alone)  # (records of several pages)
