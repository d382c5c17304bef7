"""``make demo``: the whole system in one process, on this computer's loopback.

Writes a demo world into ``./state/demo`` (a new one at every start: the demo's state is
thrown away), gives its loggers :data:`~sondalog.app.demo_world.HISTORY_DAYS` days of history
(their module time stepped fast, :mod:`sondalog.app.demo_world`), then serves, in this one
event loop:

- the virtual loggers of :data:`~sondalog.app.demo_world.LOGGERS` (module time
  :data:`SPEED` times faster than real time, ``--speed``): ``CABLE-01`` on 10001 (the ALA GPRS
  modem's port, §6.11.5.2.4; ``--listen HOST:PORT`` chooses another), ``RAIN-02`` on 10002;
- ``GSM-03`` (cable line 10003) driving its modem ``+420600000003`` of a GSM network (its
  HTTP API on 8025), served from ``gsm-site.toml`` as ``sondalog serve`` serves a site: it
  e-mails its new rows every module hour to the mail hub, and the collector reads them from
  the mailbox;
- an RS-485 bus with two HCTMPS1 modules on 10485, the mail hub (SMTP 2525, POP3 1110);
- the collector (``state/demo/collector.toml``) into SQLite, with its dashboard on 8080, and
  its alarms (:mod:`sondalog.app.demo_alarms`): the river at ``CABLE-01`` floods a module
  hour after the start; the alarm is raised, e-mailed to ``ops@example.net`` and texted
  through the GSM network to ``+420700000001``, shown, and cleared a few module hours later;
  ``GSM-03``'s modem loses coverage for a few module hours, its e-mails stop, and a
  ``no_contact`` alarm goes the same way.

A default port that is taken is replaced by a free one, and the demo says which; a port given
with ``--listen`` is used or the demo stops with a message (exit 1). It prints how to reach
each part and stops everything on Ctrl-C or SIGTERM (exit 0).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import shutil
import socket
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TypeVar

from sondalog.app.bus import BusServer, start_bus_server
from sondalog.app.collector import collect_with_dashboard
from sondalog.app.demo_alarms import (
    ALARM_PHONE,
    LEVEL_LOGGER,
    OPS_MAIL,
    RULE,
    SILENT_RULE,
    AlarmWorld,
    coverage_outage,
)
from sondalog.app.demo_world import (
    BUS_MODULES,
    GSM,
    GSM_HISTORY_DAYS,
    GSM_MODEM,
    GSM_PHONE,
    HISTORY_DAYS,
    LOGGERS,
    MAIL_ACCOUNTS,
    collector_toml,
    fast_forward,
    gsm_message_settings,
    gsm_site,
    history_origin,
    simulated_sensors,
    write_world,
)
from sondalog.app.logger import Logger, start_logger
from sondalog.app.mailhub import MailHub, MailHubConfig
from sondalog.app.serve import RunningSite, start_site
from sondalog.app.site import load_site
from sondalog.backends.sim.logger import SimHardware
from sondalog.client import Ala1Client
from sondalog.config.address import format_address, parse_listen
from sondalog.io.clock import AcceleratedClock, RealClock
from sondalog.io.loop import stop_on_signals

STATE_DIR = Path("state/demo")
HOST = "127.0.0.1"
#: Module seconds per real second while the demo runs live (a 5-minute sample every 5 s).
SPEED = 60.0
BUS_PORT, SMTP_PORT, POP3_PORT, WEB_PORT, GSM_API_PORT = 10485, 2525, 1110, 8080, 8025
#: Real seconds the demo waits for the GSM logger's first readings of signal and credit.
READINGS_TIMEOUT = 30.0
T = TypeVar("T")


class Taken(OSError):
    """A port given with ``--listen`` cannot be used."""


async def _on_port(
    what: str,
    port: int,
    start: Callable[[int], Awaitable[T]],
    bound: Callable[[T], int],
    hint: str = "",
) -> T:
    """``start(port)``, or ``start(0)`` when ``port`` is taken, saying so on stderr."""
    try:
        return await start(port)
    except OSError as exc:
        running = await start(0)
        print(
            f"port {port} is taken ({exc.strerror or exc}): {what} uses the free port "
            f"{bound(running)} instead{hint}",
            file=sys.stderr,
        )
        return running


def _free_web_port() -> int:
    """:data:`WEB_PORT`, or 0 (any free port) when it is taken."""
    with socket.socket() as probe:
        try:
            probe.bind((HOST, WEB_PORT))
        except OSError as exc:
            print(
                f"port {WEB_PORT} is taken ({exc.strerror}): the dashboard uses a free port",
                file=sys.stderr,
            )
            return 0
    return WEB_PORT


async def _until_every_channel_reads(client: Ala1Client, serial: str) -> None:
    """Wait until every channel of the logger reads a value (``read channel value``, §6.5):
    the GSM logger's signal and credit (types 12, 11) have none before its first
    communication (§6.11.7), so its live rows would start with empty fields (issue 20).
    After :data:`READINGS_TIMEOUT` real seconds the demo goes on, saying so."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + READINGS_TIMEOUT
    while True:
        answer = await client.command("read channel value")
        values = answer.lines[0].split(",") if answer.ok and answer.lines else [""]
        if all(values):
            return
        if loop.time() > deadline:
            print(
                f"{serial}: no value yet on channel(s) "
                f"{', '.join(str(n) for n, v in enumerate(values, start=1) if not v)}",
                file=sys.stderr,
            )
            return
        await asyncio.sleep(0.2)


class Demo:
    """Everything the demo started, closed in reverse by :meth:`close`."""

    def __init__(self, clock: AcceleratedClock, origin: float) -> None:
        self.clock = clock
        self.origin = origin  # where the history and the loggers' signals start
        self.loggers: dict[str, Logger] = {}
        self.bus: BusServer | None = None
        self.mail: MailHub | None = None
        self.gsm: RunningSite | None = None
        self.gsm_api = ""
        self.collector: asyncio.Task[None] | None = None
        self.web = ""
        self.web_ready: asyncio.Future[None] = asyncio.get_running_loop().create_future()

    async def start(self, listen: tuple[str, int] | None, stop: asyncio.Event) -> None:
        for number, spec in enumerate(LOGGERS):
            directory = STATE_DIR / spec.key
            # the sensors of its site file, as its history was recorded with (issue 20)
            sensors = simulated_sensors(STATE_DIR, spec, self.origin)

            async def serve(
                port: int, directory: Path = directory, sensors: SimHardware = sensors
            ) -> Logger:
                return await start_logger(directory, self.clock, (HOST, port), hardware=sensors)

            if number == 0 and listen is not None:
                try:
                    logger = await start_logger(directory, self.clock, listen, hardware=sensors)
                except OSError as exc:
                    raise Taken(f"{format_address(*listen)}: {exc.strerror or exc}") from exc
            else:
                hint = (
                    f' (choose one with: make demo ARGS="--listen {HOST}:PORT")'
                    if number == 0
                    else ""
                )
                logger = await _on_port(
                    f"logger {spec.serial}",
                    spec.port,
                    serve,
                    lambda lg: lg.servers[0].address[1],
                    hint,
                )
            self.loggers[spec.key] = logger
        self.bus = await _on_port(
            "the bus",
            BUS_PORT,
            lambda port: start_bus_server(
                RealClock(),
                (HOST, port),
                site=STATE_DIR / "bus.toml",
                state_dir=STATE_DIR / "bus",
            ),
            lambda bus: bus.address[1],
        )
        self.mail = await self._mail()
        self.gsm = await self._gsm(self.mail.smtp_port)
        web_port = _free_web_port()
        config = STATE_DIR / "collector.toml"
        # the GSM logger is in the field: its rows come by e-mail only
        addresses = {s.key: self.loggers[s.key].servers[0].address for s in LOGGERS}
        pop3 = (HOST, self.mail.pop3_port)
        alarms = AlarmWorld((HOST, self.mail.smtp_port), self.gsm_api, GSM_PHONE, self.clock.speed)
        config.write_text(
            collector_toml(addresses, self.bus.address, (HOST, web_port), pop3, alarms),
            encoding="utf-8",
        )

        def on_web(host: str, port: int) -> None:
            if not self.web_ready.done():
                self.web = f"http://{host}:{port}/"
                self.web_ready.set_result(None)

        self.collector = asyncio.create_task(
            collect_with_dashboard(config, stop, on_web), name="collector"
        )
        done, _ = await asyncio.wait(
            [self.web_ready, self.collector], return_when=asyncio.FIRST_COMPLETED
        )
        if self.collector in done:
            self.collector.result()  # raises what stopped it
            raise RuntimeError("the collector stopped before its dashboard listened")

    async def _mail(self) -> MailHub:
        async def start(smtp: int, pop3: int) -> MailHub:
            hub = MailHub(MailHubConfig(STATE_DIR / "mail", MAIL_ACCOUNTS, HOST, smtp, HOST, pop3))
            await hub.start()
            return hub

        try:
            return await start(SMTP_PORT, POP3_PORT)
        except OSError as exc:
            hub = await start(0, 0)
            print(
                f"port {SMTP_PORT} or {POP3_PORT} is taken ({exc.strerror or exc}): the mail "
                f"hub uses the free ports {hub.smtp_port} (SMTP), {hub.pop3_port} (POP3) instead",
                file=sys.stderr,
            )
            return hub

    async def _gsm(self, smtp_port: int) -> RunningSite:
        """The GSM logger with its modem and the network, as ``sondalog serve`` serves a site
        file (``gsm-site.toml``); then told to e-mail its new rows every hour."""
        site = STATE_DIR / "gsm-site.toml"
        # the modem loses coverage for a while (the network keeps real time)
        outage = coverage_outage(RealClock().now(), self.clock.speed)

        async def start(port: int, api: int) -> RunningSite:
            site.write_text(gsm_site((HOST, port), (HOST, api), outage), encoding="utf-8")
            return await start_site(load_site(site), STATE_DIR / "gsm", self.clock)

        try:
            running = await start(GSM.port, GSM_API_PORT)
        except OSError as exc:
            running = await start(0, 0)
            print(
                f"port {GSM.port} or {GSM_API_PORT} is taken ({exc.strerror or exc}): the GSM "
                "logger and the network's API use free ports",
                file=sys.stderr,
            )
        assert running.logger is not None and running.gsm_api is not None
        self.loggers[GSM.key] = running.logger
        self.gsm_api = f"http://{format_address(*running.gsm_api.address)}"
        host, port = running.logger.servers[0].address
        client = await Ala1Client.connect(f"tcp://{host}:{port}", timeout=10)
        try:
            for line in gsm_message_settings(smtp_port):
                answer = await client.command(line)
                if not answer.ok:
                    raise RuntimeError(f"{GSM.serial}: {line!r} -> {answer.lines!r}")
            await _until_every_channel_reads(client, GSM.serial)
        finally:
            await client.close()
        return running

    def describe(self) -> str:
        """What runs and how to talk to it."""
        assert self.bus is not None and self.mail is not None
        bus = f"tcp://{format_address(*self.bus.address)}"
        lines = [
            f"sondalog demo: the whole system, state in {STATE_DIR}/ (written anew at each start)",
            f"{HISTORY_DAYS} days of history recorded; module time now runs "
            f"{self.clock.speed:g}x faster.",
            "",
            f"Dashboard:  {self.web}",
            "",
            "Loggers (talk to one from another terminal):",
        ]
        for spec in (*LOGGERS, GSM):
            host, port = self.loggers[spec.key].servers[0].address
            lines.append(f"  {spec.serial}: {spec.what}")
            lines.append(f"    .venv/bin/sondalog term tcp://{host}:{port}")
        api = f"--api {self.gsm_api} " if not self.gsm_api.endswith(f":{GSM_API_PORT}") else ""
        lines += [
            f"    its modem {GSM_MODEM}; text it from the phone {GSM_PHONE} and read the reply:",
            f"    .venv/bin/sondalog phone {api}sms {GSM_PHONE} {GSM_MODEM} "
            "'##*#read i snumber##*#'",
            f"    .venv/bin/sondalog phone {api}inbox {GSM_PHONE}",
        ]
        first = next(iter(BUS_MODULES))
        lines += [
            "",
            f"RS-485 bus with HCTMPS1 modules {', '.join(BUS_MODULES)}:",
            f"  .venv/bin/sondalog bus scan {bus}",
            f"  .venv/bin/sondalog bus ask {bus} {first} PV",
            "",
            f"Mail hub: SMTP {HOST}:{self.mail.smtp_port}, POP3 {HOST}:{self.mail.pop3_port}"
            f" (accounts {', '.join(MAIL_ACCOUNTS)}, password secret)",
            f"Collector: {STATE_DIR}/collector.toml -> {STATE_DIR}/collector.sqlite",
            "",
            f"Alarms: the river at {LEVEL_LOGGER} floods about a module hour after the start: "
            f"the alarm {RULE!r} is raised (dashboard, e-mail to {OPS_MAIL}, SMS from "
            f"{ALARM_PHONE} to {GSM_PHONE}) and cleared a few module hours later.",
            f"  {GSM.serial} loses coverage for a few module hours: no e-mail comes, and the "
            f"alarm {SILENT_RULE!r} is raised, e-mailed and texted, then cleared by its next "
            "e-mail.",
            f"  .venv/bin/sondalog alarms list {STATE_DIR}/collector.toml",
            f"  .venv/bin/sondalog alarms ack {STATE_DIR}/collector.toml ID",
            f"  .venv/bin/sondalog phone {api}inbox {GSM_PHONE}",
            "",
            "Serving until Ctrl-C.",
        ]
        return "\n".join(lines)

    async def close(self) -> None:
        if self.collector is not None:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await asyncio.wait_for(self.collector, 10)
        if self.gsm is not None:
            self.loggers.pop(GSM.key, None)
            await self.gsm.close()
        if self.mail is not None:
            with contextlib.suppress(Exception):
                await self.mail.stop()
        if self.bus is not None:
            await self.bus.close()
        for logger in self.loggers.values():
            await logger.close()


def _arguments(argv: list[str] | None) -> tuple[tuple[str, int] | None, float]:
    parser = argparse.ArgumentParser(
        prog="python -m sondalog.demo",
        description="Serve virtual loggers, a bus, a mail hub and the collector with its "
        "dashboard.",
    )
    parser.add_argument(
        "--listen",
        metavar="HOST:PORT",
        help=f"address of the first logger (default {HOST}:{LOGGERS[0].port}, or a free port "
        "if taken)",
    )
    parser.add_argument(
        "--speed",
        type=float,
        default=SPEED,
        help=f"module seconds per real second while live (default {SPEED:g})",
    )
    args = parser.parse_args(argv)
    if args.speed <= 0:
        parser.error("--speed: must be more than 0")
    if args.listen is None:
        return None, args.speed
    try:
        return parse_listen(args.listen), args.speed
    except ValueError as exc:
        parser.error(f"--listen: {exc}")  # exits with status 2


async def main(listen: tuple[str, int] | None = None, speed: float = SPEED) -> None:
    stop = stop_on_signals()
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if STATE_DIR.exists():
        shutil.rmtree(STATE_DIR)
    write_world(STATE_DIR)
    print(f"recording {HISTORY_DAYS} days of history ...", flush=True)
    origin = history_origin()
    for spec in LOGGERS:
        await asyncio.to_thread(fast_forward, STATE_DIR, spec, HISTORY_DAYS, None, origin)
    gsm_logger = STATE_DIR / GSM.key / "logger"  # where start_site keeps the site's logger
    await asyncio.to_thread(fast_forward, STATE_DIR, GSM, GSM_HISTORY_DAYS, gsm_logger)
    demo = Demo(AcceleratedClock(speed), origin)
    try:
        if not stop.is_set():
            await demo.start(listen, stop)
            print(demo.describe(), flush=True)
            await stop.wait()
    except Taken as exc:
        print(f"cannot serve the demo on {exc}", file=sys.stderr)
        raise SystemExit(1) from None
    finally:
        stop.set()
        await demo.close()
    print("stopped.")


if __name__ == "__main__":
    asyncio.run(main(*_arguments(None)))
