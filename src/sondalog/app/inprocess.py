"""A site served in the caller's own event loop, with a clock a test can step (issue 23).

:func:`start_inprocess` starts what a site file describes (:func:`~sondalog.app.serve.
start_site`: loggers, bus, mail hub, GSM network; a fleet) on a :class:`SteppableClock`:
real time, plus the jumps a test asks for. :meth:`InProcessSite.step` jumps it and returns
once every device ran what was due (every sample of six hours, say); :meth:`InProcessSite.
set_input` changes a simulated input of the logger. ``sondalog.testing`` builds its pytest
fixtures on this; the control API (``serve --control``) offers the same over HTTP.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.ala1.engine import Engine
from sondalog.app.serve import RunningSite, start_site
from sondalog.app.site import SitePlan, load_site
from sondalog.backends.sim.logger import SimHardware
from sondalog.backends.sim.signals import Signal
from sondalog.config.address import format_address
from sondalog.io.host import DeviceHost

#: How many turns of the event loop :meth:`InProcessSite.step` waits at most for the devices
#: to run what is due (each turn runs every timer that is due; a few suffice).
_SETTLE_TURNS = 10_000


class SteppableClock:
    """Wall-clock time plus the jumps :meth:`step` made. A timer sleeping towards a deadline
    wakes at a jump, so what the jump made due runs at once."""

    speed = 1.0

    def __init__(self) -> None:
        self.offset = 0.0
        self._jumped = asyncio.Event()

    def now(self) -> float:
        return time.time() + self.offset

    def step(self, seconds: float) -> float:
        """Jump ``seconds`` forward; returns the new time."""
        if seconds < 0:
            raise ValueError("a clock does not run backwards")
        self.offset += seconds
        self._jumped.set()
        self._jumped = asyncio.Event()
        return self.now()

    async def sleep_until(self, deadline: float) -> None:
        while (delay := deadline - self.now()) > 0:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._jumped.wait(), delay)


class UnknownInput(KeyError):
    """An input a logger does not have (the message names the ones it has)."""

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass
class InProcessSite:
    """A running site, its clock and where each part listens."""

    running: RunningSite
    clock: SteppableClock
    urls: dict[str, str] = field(default_factory=dict)
    """``logger``, ``bus``, ``gsm`` (the network's HTTP API), ``modem:NUMBER``, ``fleet:N``."""

    def hosts(self) -> list[DeviceHost]:
        """Every device host of the site (the ones :meth:`step` waits for)."""
        running = self.running
        found: list[DeviceHost] = []
        if running.logger is not None:
            found.append(running.logger.host)
        if running.bus is not None:
            found.append(running.bus.host)
        if running.gsm is not None:
            found += [running.gsm.net_host, *running.gsm.modem_hosts.values()]
        if running.fleet is not None:
            found += [member.host for member in running.fleet.members]
        return found

    async def step(self, seconds: float) -> None:
        """Let ``seconds`` pass at once; returns when every device ran what was due."""
        now = self.clock.step(seconds)
        for _ in range(_SETTLE_TURNS):
            await asyncio.sleep(0)
            if all(_settled(host, now) for host in self.hosts()):
                return
        raise TimeoutError("the devices did not catch up with the clock")

    def set_input(self, what: str, value: float | Signal) -> None:
        """Set a simulated input of the logger: ``supply``, ``analog:16``,
        ``ds18b20:<rom hex>``, ``gsm:signal``, ``gsm:credit``; a number is a constant."""
        hardware = self._hardware()
        try:
            hardware.set_signal(what, value)
        except (KeyError, ValueError, StopIteration):
            raise UnknownInput(
                f"the logger has no input {what!r} (inputs: {', '.join(inputs(hardware))})"
            ) from None

    def _hardware(self) -> SimHardware:
        logger = self.running.logger
        if logger is None:
            raise UnknownInput("the site has no [logger]")
        engine = logger.host.device
        assert isinstance(engine, Engine)
        hardware = engine.state.hardware
        if not isinstance(hardware, SimHardware):
            raise UnknownInput("the logger's hardware is not simulated (backend is not sim)")
        return hardware

    async def close(self) -> None:
        await self.running.close()


def inputs(hardware: SimHardware) -> list[str]:
    """The names :meth:`InProcessSite.set_input` takes for ``hardware``."""
    names = [
        "supply",
        *(f"analog:{a}" for a in sorted(x.address for x in hardware.analog.values())),
    ]
    names += [f"ds18b20:{t.rom:016x}" for t in hardware.thermometers]
    return [*names, "gsm:signal", "gsm:credit"]


def _settled(host: DeviceHost, now: float) -> bool:
    deadline = host.device.next_deadline()
    return deadline is None or deadline > now


async def start_inprocess(site: Path | SitePlan, state: Path) -> InProcessSite:
    """Start ``site`` (a site file or its loaded plan) with its state in ``state``; raises
    :class:`~sondalog.config.ConfigError` for a bad file, ``OSError`` for a busy port."""
    plan = load_site(site) if isinstance(site, Path) else site
    clock = SteppableClock()
    running = await start_site(plan, state, clock)
    started = InProcessSite(running, clock)
    urls = started.urls
    if running.logger is not None:
        urls["logger"] = _tcp(running.logger.servers[0].address)
    if running.bus is not None:
        urls["bus"] = _tcp(running.bus.address)
    if running.gsm_api is not None:
        urls["gsm"] = f"http://{format_address(*running.gsm_api.address)}"
    if running.gsm is not None:
        for number, server in running.gsm.servers.items():
            urls[f"modem:{number}"] = _tcp(server.address)
    if running.fleet is not None:
        for index, member in enumerate(running.fleet.members):
            urls[f"fleet:{index}"] = _tcp(member.server.address)
    return started


def _tcp(address: tuple[str, int]) -> str:
    return f"tcp://{format_address(*address)}"
