"""``sondalog serve SITE.toml``: everything a site file describes, in one process.

The wiring of :mod:`sondalog.app.site`'s plan: the logger (its hardware from the backend the
site names, its state in ``STATE/logger``), the RS-485 bus (``STATE/bus``) and the mail hub
(``STATE/mail``), each served by the one runtime on one clock. Later issues add fleets of
loggers and the GSM network here, not in the CLI.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from sondalog.ala1.model import Version
from sondalog.app.bus import BusServer, start_bus_server
from sondalog.app.logger import Logger, start_logger
from sondalog.app.mailhub import MailHub, config_from_mapping
from sondalog.app.site import SitePlan
from sondalog.backends.linux.rs485 import Rs485Error
from sondalog.backends.registry import Acquiring, BackendContext, create
from sondalog.io.address import format_address
from sondalog.io.clock import Clock
from sondalog.sitefile import SiteError, locate

#: The environment variable naming the root of sysfs and /dev (default "/").
ROOT_VARIABLE = "SONDALOG_ROOT"
#: Called with a line to show the user once each part is ready.
Announce = Callable[[str], None]


@dataclass
class RunningSite:
    """What :func:`start_site` started; :meth:`close` stops all of it."""

    logger: Logger | None = None
    bus: BusServer | None = None
    mail: MailHub | None = None
    acquisition: asyncio.Task[None] | None = None

    async def close(self) -> None:
        if self.acquisition is not None:
            self.acquisition.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self.acquisition
        if self.mail is not None:
            with contextlib.suppress(Exception):
                await self.mail.stop()
        if self.bus is not None:
            await self.bus.close()
        if self.logger is not None:
            await self.logger.close()


async def start_site(
    plan: SitePlan, state: Path, clock: Clock, announce: Announce = lambda line: None
) -> RunningSite:
    """Start every part of ``plan``; raises :class:`SiteError` or OSError.

    The environment variable ``SONDALOG_ROOT`` prefixes every sysfs and ``/dev`` path the
    real sensors are read from (a fake kernel tree in tests, a chroot)."""
    root = Path(os.environ.get(ROOT_VARIABLE) or "/")
    running = RunningSite()
    try:
        if plan.logger is not None:
            logger = plan.logger
            context = BackendContext(plan.data, plan.path, plan.text, clock.now(), root)
            try:
                hardware = create(logger.backend, context)
            except LookupError as exc:
                raise SiteError(
                    plan.path, "logger.backend", str(exc), locate(plan.text, "logger.backend")
                ) from exc
            if isinstance(hardware, Acquiring):  # a real board: its acquisition task runs here
                running.acquisition = asyncio.create_task(hardware.run(), name="acquisition")
            running.logger = await start_logger(
                state / "logger",
                clock,
                logger.listen,
                Version(logger.protocol) if logger.protocol else None,
                logger.serial_number,
                hardware=hardware,
                ptys=logger.ptys,
                serials=logger.serials,
                line_rate=logger.line_rate,
            )
            address = running.logger.servers[0].address
            announce(
                f"logger {running.logger.identity.serial_number} listening on "
                f"{format_address(*address)}"
            )
            for pty in running.logger.ptys:
                announce(f"logger pty {pty.link} -> {pty.device}")
        if plan.bus is not None:
            bus = plan.bus
            try:
                running.bus = await start_bus_server(
                    clock, bus.listen, site=plan.path, state_dir=state / "bus", pty=bus.pty,
                    serial=bus.serial, rs485=bus.rs485, root=root, baud=bus.baud,
                )  # fmt: skip
            except Rs485Error as exc:
                table = plan.data.get("bus")
                serve = table.get("serve") if isinstance(table, Mapping) else None
                where = (
                    "bus.serve.rs485"
                    if isinstance(serve, Mapping) and "rs485" in serve
                    else "board.rs485"
                )
                raise SiteError(plan.path, where, str(exc), locate(plan.text, where)) from exc
            announce(f"bus listening on {format_address(*running.bus.address)}")
            if running.bus.serial is not None and bus.rs485 is not None:
                announce(f"bus RS-485 ({bus.rs485.mode}) on {bus.serial}")
        if plan.mail is not None:
            try:
                config = config_from_mapping(plan.mail, state / "mail")
            except ValueError as exc:
                raise SiteError(plan.path, "mail", str(exc), locate(plan.text, "mail")) from exc
            running.mail = MailHub(config)
            await running.mail.start()
            announce(
                f"mail SMTP on {config.smtp_host}:{running.mail.smtp_port}, "
                f"POP3 on {config.pop3_host}:{running.mail.pop3_port}"
            )
    except BaseException:
        await running.close()
        raise
    return running
