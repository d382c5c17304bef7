"""``sondalog bus serve``: a virtual RS-485 bus with its modules and ports (the wiring).

:func:`start_bus_server` takes the bus part of a site file, loaded once into a typed plan
(:class:`~sondalog.backends.sim.site_bus.BusSite`; or the default ``T1`` + ``H1``), opens the EEPROM
database in the state directory, puts the modules on a :class:`~sondalog.world.bus.BusCore`,
serves it with the one runtime (:class:`~sondalog.io.host.DeviceHost`) and opens the lines:
TCP always (each connection its own node, as if each client had its own TCP-to-RS-485
gateway: it does not hear its own bytes, but hears every other node), a pty and a serial line
on request.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

from sondalog.app.bus_build import build_bus
from sondalog.backends.linux.rs485 import Rs485Settings, open_rs485
from sondalog.backends.sensor_bank import SensorBank
from sondalog.backends.sim.site_bus import BusSite, default_bus_site, load_bus_site
from sondalog.backends.store.eeprom import EepromDatabase
from sondalog.io.clock import Clock
from sondalog.io.host import DeviceHost
from sondalog.io.pty import PtyLine
from sondalog.io.rs485 import Mode, Rs485Line
from sondalog.io.serial_line import SerialLine
from sondalog.io.tcp import TcpServer, serve_tcp
from sondalog.world.bus import BusCore

log = logging.getLogger(__name__)

#: Default TCP port of ``bus serve`` (10485: "RS-485").
DEFAULT_PORT = 10485


@dataclass
class BusServer:
    """A running bus and everything attached to it."""

    core: BusCore
    host: DeviceHost
    server: TcpServer
    database: EepromDatabase | None
    pty: PtyLine | None = None
    serial: SerialLine | Rs485Line | None = None
    acquisition: asyncio.Task[None] | None = None  # the real sensors' (SensorBank.run)

    @property
    def address(self) -> tuple[str, int]:
        return self.server.address

    async def close(self) -> None:
        if self.acquisition is not None:
            self.acquisition.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self.acquisition
        with contextlib.suppress(Exception):
            await self.server.close()
        if self.pty is not None:
            self.pty.close()
        if self.serial is not None:
            await self.serial.close()
        await self.host.stop()
        if self.database is not None:
            self.database.close()


def rs485_settings(mode: Mode) -> Rs485Settings:
    """How ``bus serve --rs485 MODE`` drives its adapter (the other settings: defaults)."""
    return Rs485Settings(mode)


def bus_plan(site: BusSite | Path | None) -> BusSite:
    """The bus of ``site``: a plan already loaded, the site file at a path (read here), or
    the default ``T1`` + ``H1``; raises :class:`~sondalog.config.ConfigError`."""
    if site is None:
        return default_bus_site()
    if isinstance(site, BusSite):
        return site
    return load_bus_site(site)


async def start_bus_server(
    clock: Clock,
    listen: tuple[str, int] = ("127.0.0.1", DEFAULT_PORT),
    *,
    site: BusSite | Path | None = None,
    state_dir: Path | None = None,
    baud: int | None = None,
    pty: Path | None = None,
    serial: str | None = None,
    noise: float | None = None,
    seed: int | None = None,
    rs485: Rs485Settings | None = None,
    root: Path = Path("/"),
) -> BusServer:
    """Start the bus ``site`` (a :class:`BusSite` plan as loaded with its site file; a path
    is loaded first, ``None`` is the default bus); raises
    :class:`~sondalog.config.ConfigError` for a bad site file.

    ``serial`` with ``rs485`` opens the port as an RS-485 adapter (:func:`open_rs485`);
    modules with a real ``source`` read sysfs under ``root``."""
    plan = bus_plan(site)
    now = clock.now()
    sensors = await _sensors(plan, root)
    core, database = build_bus(plan, now, baud, state_dir, noise, seed, sensors)
    host = DeviceHost(core, clock)
    host.start()
    running: BusServer | None = None
    try:
        running = BusServer(core, host, await serve_tcp(host, *listen), database)
        if sensors.sensors:
            running.acquisition = asyncio.create_task(sensors.run(), name="bus sensors")
        if pty is not None:
            running.pty = PtyLine(host, pty, keep_slave=True)
        if serial is not None:
            running.serial = _serial_line(host, serial, core.baud, rs485)
            await running.serial.open()
    except BaseException:
        if running is not None:
            await running.close()
        else:
            await host.stop()
            if database is not None:
                database.close()
        raise
    ids = ", ".join(a.module.module_id for a in core.modules)
    log.info("bus at %d baud with %s", core.baud, ids)
    return running


async def _sensors(plan: BusSite, root: Path) -> SensorBank:
    """The real sensors of ``plan``'s modules, read once before the modules' power-up
    measurement."""
    sensors = SensorBank(root)
    for entry in plan.modules:
        if entry.source is not None:
            sensors.sensor(entry.source)
    if sensors.sensors:
        await sensors.acquire()
    return sensors


def _serial_line(
    host: DeviceHost, serial: str, baud: int, rs485: Rs485Settings | None
) -> SerialLine | Rs485Line:
    """The bus's line on a real serial port (not opened yet): a plain port, or an RS-485
    adapter driven as ``rs485`` says."""
    if rs485 is None:
        return SerialLine(host, serial)
    how = rs485

    def opener() -> object:
        return open_rs485(
            serial,
            baud,
            mode=how.mode,
            delay_before_tx=how.delay_before_tx,
            delay_before_rx=how.delay_before_rx,
        )

    return Rs485Line(host, opener, serial)
