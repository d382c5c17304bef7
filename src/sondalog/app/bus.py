"""``sondalog bus serve``: a virtual RS-485 bus with its modules and ports (the library side).

:func:`start_bus_server` loads the site (or the default ``T1`` + ``H1``), opens the EEPROM
database in the state directory, puts the modules on a :class:`~sondalog.world.bus.BusCore`,
runs it on the clock and opens the ports: TCP always, a pty and a serial line on request.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

from sondalog.app.bus_build import build_bus
from sondalog.backends.sim.site_bus import default_bus_site, load_bus_site
from sondalog.backends.store.eeprom import EepromDatabase
from sondalog.io.bus_ports import PtyPort, open_serial, serve_tcp
from sondalog.io.bus_runner import VirtualBus
from sondalog.io.clock import Clock
from sondalog.world.bus import BusCore

log = logging.getLogger(__name__)

#: Default TCP port of ``bus serve`` (10485: "RS-485").
DEFAULT_PORT = 10485


@dataclass
class BusServer:
    """A running bus and everything attached to it."""

    core: BusCore
    bus: VirtualBus
    server: asyncio.Server
    runner: asyncio.Task[None]
    database: EepromDatabase | None
    pty: PtyPort | None = None
    serial: asyncio.Task[None] | None = None

    @property
    def address(self) -> tuple[str, int]:
        host, port = self.server.sockets[0].getsockname()[:2]
        return str(host), int(port)

    async def close(self) -> None:
        self.server.close()
        with contextlib.suppress(Exception):
            await asyncio.wait_for(self.server.wait_closed(), 1.0)
        if self.pty is not None:
            self.pty.close()
        for task in (self.serial, self.runner):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
        if self.database is not None:
            self.database.close()


async def start_bus_server(
    clock: Clock,
    listen: tuple[str, int] = ("127.0.0.1", DEFAULT_PORT),
    *,
    site: Path | None = None,
    state_dir: Path | None = None,
    baud: int | None = None,
    pty: Path | None = None,
    serial: str | None = None,
    noise: float | None = None,
    seed: int | None = None,
) -> BusServer:
    """Start a bus; raises :class:`~sondalog.sitefile.SiteError` for a bad site file."""
    now = clock.now()
    bus_site = load_bus_site(site, now) if site is not None else default_bus_site(now)
    core, database = build_bus(bus_site, now, baud, state_dir, noise, seed)
    bus = VirtualBus(core, clock)
    runner = asyncio.create_task(bus.run(), name="bus")
    server: asyncio.Server | None = None
    running: BusServer | None = None
    try:
        server = await serve_tcp(bus, *listen)
        running = BusServer(core, bus, server, runner, database)
        if pty is not None:
            running.pty = PtyPort(bus, pty)
        if serial is not None:
            running.serial = await open_serial(bus, serial, core.baud)
    except BaseException:
        if running is not None:
            await running.close()
        else:
            runner.cancel()
            if database is not None:
                database.close()
        raise
    ids = ", ".join(a.module.module_id for a in core.modules)
    log.info("bus at %d baud with %s", core.baud, ids)
    return running
