"""``sondalog serve SITE.toml``: everything a site file describes, in one process.

The wiring of :mod:`sondalog.app.site`'s plan: the logger (its hardware from the backend the
site names, its state in ``STATE/logger``), the RS-485 bus (``STATE/bus``), the mail hub
(``STATE/mail``) and the GSM network (``STATE/gsm``, :mod:`sondalog.app.gsm`), each served by
the one runtime on one clock. Later issues add fleets of loggers here, not in the CLI.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from sondalog.ala1.engine import Engine
from sondalog.ala1.model import Version
from sondalog.app.bus import BusServer, start_bus_server
from sondalog.app.fleet import RunningFleet, start_fleet
from sondalog.app.gsm import GsmRuntime
from sondalog.app.gsm_api import ApiServer
from sondalog.app.gsm_site import traced
from sondalog.app.logger import Logger, sensor_root, start_logger
from sondalog.app.mailhub import MailHub
from sondalog.app.site import SitePlan
from sondalog.backends.linux.rs485 import Rs485Error
from sondalog.config.address import format_address
from sondalog.io.clock import Clock, RealClock
from sondalog.io.private import private_dir

#: Called with a line to show the user once each part is ready.
Announce = Callable[[str], None]


@dataclass
class RunningSite:
    """What :func:`start_site` started; :meth:`close` stops all of it."""

    logger: Logger | None = None
    bus: BusServer | None = None
    mail: MailHub | None = None
    gsm: GsmRuntime | None = None
    gsm_api: ApiServer | None = None
    fleet: RunningFleet | None = None

    async def close(self) -> None:
        if self.fleet is not None:
            await self.fleet.close()
        if self.gsm_api is not None:
            await self.gsm_api.stop()
        if self.gsm is not None:
            await self.gsm.close()
        if self.mail is not None:
            with contextlib.suppress(Exception):
                await self.mail.stop()
        if self.bus is not None:
            await self.bus.close()
        if self.logger is not None:
            await self.logger.close()


async def start_site(
    plan: SitePlan,
    state: Path,
    clock: Clock,
    announce: Announce = lambda line: None,
    trace: Path | None = None,
) -> RunningSite:
    """Start every part of ``plan``; raises :class:`ConfigError` or OSError.

    Nothing here reads the site file again: the logger's hardware, the fleet's, the bus and
    the GSM network's models are built from the plans :func:`load_site` made.

    The environment variable ``SONDALOG_ROOT`` prefixes every sysfs and ``/dev`` path the
    real sensors are read from (a fake kernel tree in tests, a chroot). ``trace``
    (``--trace FILE``): record the line of the logger's modem (``[gsm] logger_modem``, else the
    first modem) in FILE."""
    root = sensor_root()
    running = RunningSite()
    private_dir(state)  # 0700 and every file in it 0600, whatever the umask (docs/security.md)
    try:
        if plan.logger is not None:
            logger = plan.logger
            hardware = logger.hardware.build(clock.now(), root, clock.speed)
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
        if plan.fleet:
            running.fleet = await start_fleet(plan.fleet, state, clock, plan.path, announce)
        if plan.bus is not None:
            bus = plan.bus
            try:
                running.bus = await start_bus_server(
                    clock, bus.listen, site=bus.site, state_dir=state / "bus", pty=bus.pty,
                    serial=bus.serial, rs485=bus.rs485, root=root, baud=bus.baud,
                )  # fmt: skip
            except Rs485Error as exc:
                raise plan.root.fail(bus.rs485_field, str(exc)) from exc
            announce(f"bus listening on {format_address(*running.bus.address)}")
            if running.bus.serial is not None and bus.rs485 is not None:
                announce(f"bus RS-485 ({bus.rs485.mode}) on {bus.serial}")
        if plan.mail is not None:
            config = replace(plan.mail, root=state / "mail")
            running.mail = MailHub(config)
            await running.mail.start()
            announce(
                f"mail SMTP on {config.smtp_host}:{running.mail.smtp_port}, "
                f"POP3 on {config.pop3_host}:{running.mail.pop3_port}"
            )
        if plan.gsm is not None:
            # the network and its modems are lines: they keep real time under --speed
            gsm_clock = clock if clock.speed == 1 else RealClock()
            gsm = plan.gsm.at(gsm_clock.now())
            if trace is not None:
                gsm = traced(gsm, trace)
            running.gsm = GsmRuntime(gsm, state / "gsm", gsm_clock)
            await running.gsm.start()
            running.gsm_api = ApiServer(running.gsm, *plan.gsm.api)
            await running.gsm_api.start()
            announce(f"gsm API on http://{format_address(*running.gsm_api.address)}")
            for number, server in running.gsm.servers.items():
                announce(f"gsm modem {number} listening on {format_address(*server.address)}")
            for pty in running.gsm.ptys:
                announce(f"gsm modem pty {pty.link} -> {pty.device}")
            modem_number = plan.logger.modem if plan.logger is not None else None
            if running.logger is not None and modem_number:
                join_modem(running.logger, running.gsm, modem_number, clock.now())
                announce(f"logger com line joined to its modem {modem_number}")
    except BaseException:
        await running.close()
        raise
    return running


def join_modem(logger: Logger, gsm: GsmRuntime, number: str, now: float) -> None:
    """The logger drives its modem through AT bytes on its com line (gsm notes §1): the
    engine's modem line is joined to the DTE side of modem ``number``."""
    host = logger.host
    engine = host.device
    assert isinstance(engine, Engine)
    line = engine.attach_modem(now)
    modem = gsm.dte(number, lambda data: host.deliver(line, data))
    host.adopt(line, lambda output: modem.write(output.data))
