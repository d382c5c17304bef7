"""A fleet of virtual loggers served by one process (issue 11; docs/scaling.md).

The wiring of :mod:`sondalog.app.fleet_site`'s ``[[loggers]]``: every logger has its own
engine, :class:`~sondalog.io.host.DeviceHost` and TCP server on the one event loop, all on one
deadline loop (:class:`~sondalog.io.timers.Timers`: loggers sampling on the same minute are
run in slices, and input is answered between them, issue 24), its own
state directory ``STATE/loggers/SERIAL`` (``identity.json``: protocol and serial number, as
for ``sondalog logger serve``) and its memory under its serial number in the fleet's shared
database ``STATE/loggers/fleet.sqlite`` (:mod:`sondalog.backends.store.ala1_nv`): the rows
all loggers sample in one event-loop turn are committed in one transaction, a command line's
changes at once, before its ``OK``. Log lines written while a logger works start with
``[logger SERIAL]``.
"""

from __future__ import annotations

import asyncio
import contextvars
import gc
import logging
import resource
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sondalog.ala1 import Engine
from sondalog.app.fleet_identity import read_identities, write_identities
from sondalog.app.fleet_site import FleetLogger
from sondalog.app.logger import sensor_root
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.config.address import format_address
from sondalog.io.clock import Clock
from sondalog.io.host import DeviceHost
from sondalog.io.private import private_dir
from sondalog.io.tcp import TcpServer, serve_tcp
from sondalog.io.timers import PAUSE, Timers
from sondalog.protocol.device import Effect, Event

DATABASE_FILE = "fleet.sqlite"
#: Seconds between two checkpoints of the fleet's database, in a thread (issue 24).
CHECKPOINT_EVERY = 5.0
#: Seconds between two freezes of what the fleet holds (:meth:`RunningFleet.freeze`).
FREEZE_EVERY = 60.0
#: Collections of the middle generation before the collector itself collects all (10).
FULL_COLLECTIONS_AFTER = 100_000
#: Freezes between two full collections of the fleet (hourly).
FULL_EVERY = 60

#: The serial number of the logger whose engine is running (for log lines).
_CURRENT: contextvars.ContextVar[str | None] = contextvars.ContextVar(
    "sondalog_logger", default=None
)


class NamedDevice:
    """A logger's engine, with its serial number on every log line it writes."""

    def __init__(self, engine: Engine, name: str) -> None:
        self.engine = engine
        self.name = name

    def open_line(self, *, paced: bool = False) -> int:
        return self.engine.open_line(paced=paced)

    def close_line(self, line: int) -> None:
        token = _CURRENT.set(self.name)
        try:
            self.engine.close_line(line)
        finally:
            _CURRENT.reset(token)

    def line_speed(self) -> int:
        return self.engine.line_speed()

    def input_room(self, line: int) -> int | None:
        return self.engine.input_room(line)  # DeviceHost's backpressure (issue 20)

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        token = _CURRENT.set(self.name)
        try:
            return self.engine.receive(line, data, now)
        finally:
            _CURRENT.reset(token)

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        token = _CURRENT.set(self.name)
        try:
            return self.engine.handle(event, now)
        finally:
            _CURRENT.reset(token)

    def advance(self, now: float) -> Sequence[Effect]:
        token = _CURRENT.set(self.name)
        try:
            return self.engine.advance(now)
        finally:
            _CURRENT.reset(token)

    def next_deadline(self) -> float | None:
        return self.engine.next_deadline()


def install_log_names() -> None:
    """Prefix the log lines written inside a fleet logger's engine with its name."""
    previous = logging.getLogRecordFactory()
    if getattr(previous, "sondalog_fleet", False):
        return

    def factory(*args: Any, **kwargs: Any) -> logging.LogRecord:
        record = previous(*args, **kwargs)
        name = _CURRENT.get()
        if name is not None:  # serial numbers hold no '%' (fleet_site._SERIAL)
            record.msg = f"[logger {name}] {record.msg}"
        return record

    factory.sondalog_fleet = True  # type: ignore[attr-defined]
    logging.setLogRecordFactory(factory)


@dataclass
class FleetMember:
    serial_number: str
    engine: Engine
    host: DeviceHost
    server: TcpServer


@dataclass
class RunningFleet:
    """The loggers of a fleet and their shared database; :meth:`close` stops them all."""

    database: NvDatabase
    members: list[FleetMember] = field(default_factory=list)
    freezer: asyncio.TimerHandle | None = None
    thresholds: tuple[int, int, int] = (700, 10, 10)  # the collector's, before the fleet
    rounds: int = 0  # freezes so far

    async def close(self) -> None:
        if self.freezer is not None:
            self.freezer.cancel()
            gc.unfreeze()  # what the fleet held can be collected again
            gc.set_threshold(*self.thresholds)
        for member in self.members:
            await member.server.close()
            await member.host.stop()
        self.database.close()

    def freeze(self) -> None:
        """Keep the fleet's long-lived objects out of the garbage collector's sight.

        Ten thousand loggers are millions of objects that live as long as the process: a full
        collection over them stopped the process for a second now and then (issue 24). They
        are frozen (``gc.freeze``) after start, and every :data:`FREEZE_EVERY` seconds what
        survived the young generations' collection since. Even a minute's survivors of
        10,000 loggers sampling take 0.3 s to collect in full, so the collector's own full
        collections wait (its third threshold raised), and the fleet's full collection
        (thawed: cycles frozen meanwhile are freed) runs once per :data:`FULL_EVERY` rounds."""
        loop = asyncio.get_running_loop()
        if self.freezer is None:
            self.thresholds = gc.get_threshold()
            gc.set_threshold(self.thresholds[0], self.thresholds[1], FULL_COLLECTIONS_AFTER)
        self.rounds += 1
        if self.rounds % FULL_EVERY == 0:
            gc.unfreeze()
            gc.collect()
        else:
            gc.collect(1)
        gc.freeze()
        self.freezer = loop.call_later(FREEZE_EVERY, self.freeze)


def _raise_open_files(needed: int) -> None:
    """Each logger holds a listening socket: lift the soft limit on open files if needed."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < needed:
        target = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))


async def start_fleet(
    loggers: Sequence[FleetLogger],
    state: Path,
    clock: Clock,
    path: Path | None,
    announce: Callable[[str], None] = lambda line: None,
) -> RunningFleet:
    """Start every logger of ``loggers`` (state under ``state``), each with its own hardware
    built from its entry's plan (the backend registry); raises ConfigError/OSError."""
    install_log_names()
    _raise_open_files(len(loggers) + 1024)
    states = state / "loggers"
    private_dir(states)  # 0700, like every state directory (docs/security.md)
    loop = asyncio.get_running_loop()

    def schedule(callback: Callable[[], None]) -> None:
        loop.call_soon(callback)

    database = NvDatabase(
        states / DATABASE_FILE, schedule, checkpoint_every=CHECKPOINT_EVERY, background=True
    )
    fleet = RunningFleet(database)
    # one deadline loop for all, its due work in slices with rests between (issue 24)
    timers = Timers(clock, pause_seconds=PAUSE)
    root = sensor_root()
    try:
        identities, new = read_identities(loggers, states, path)
        write_identities(states, new)  # durable before anything the loggers commit
        serials = [plan.serial_number for plan in loggers]
        engines = []
        # a new fleet's first commits: one transaction; every logger's memory read at once
        with fleet.database.batch(), fleet.database.preloaded(serials):
            for plan, identity in zip(loggers, identities, strict=True):
                now = clock.now()
                hardware = plan.hardware.build(now, root, clock.speed)  # its own, from the plan
                store = fleet.database.store(plan.serial_number)
                engines.append(Engine(identity, store, now, hardware, line_time_scale=clock.speed))
        for plan, engine in zip(loggers, engines, strict=True):
            host = DeviceHost(NamedDevice(engine, plan.serial_number), clock, timers)
            server = await serve_tcp(host, *plan.listen)
            host.start()
            fleet.members.append(FleetMember(plan.serial_number, engine, host, server))
            announce(f"logger {plan.serial_number} listening on {format_address(*server.address)}")
    except BaseException:
        await fleet.close()
        raise
    fleet.freeze()
    return fleet
