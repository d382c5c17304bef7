"""A site served in the caller's own event loop, with a clock a test can step (issue 23).

:func:`start_inprocess` starts what a site file describes (:func:`~sondalog.app.serve.
start_site`: loggers, bus, mail hub, GSM network; a fleet) on the control API's clock
(:class:`~sondalog.io.clock_control.ControlledClock`: real time until told otherwise), runs
its ``[[scenario]]`` and serves its control API on a free loopback port
(:attr:`InProcessSite.control_url`, as ``serve --control`` would). :meth:`InProcessSite.step`
jumps the clock (stopping at each scenario step on the way) and returns once every device ran
what was due (every sample of six hours, say); :meth:`InProcessSite.set_input` changes a
simulated input of the logger. ``sondalog.testing`` builds its pytest fixtures on this.
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.ala1.engine import Engine
from sondalog.app.control import Controller
from sondalog.app.control_actions import Step
from sondalog.app.control_api import ControlServer
from sondalog.app.scenario_run import site_control
from sondalog.app.serve import RunningSite, start_site
from sondalog.app.site import SitePlan, load_site
from sondalog.backends.sim.logger import SimHardware
from sondalog.backends.sim.signals import Signal
from sondalog.config.address import format_address
from sondalog.io.clock_control import ControlledClock
from sondalog.io.host import DeviceHost

#: How many turns of the event loop :meth:`InProcessSite.step` waits at most for the devices
#: to run what is due (each turn runs every timer that is due; a few suffice).
_SETTLE_TURNS = 10_000


class UnknownInput(KeyError):
    """An input a logger does not have (the message names the ones it has)."""

    def __str__(self) -> str:
        return str(self.args[0])


@dataclass
class InProcessSite:
    """A running site, its clock and where each part listens."""

    running: RunningSite
    clock: ControlledClock
    control: Controller
    server: ControlServer | None = None
    urls: dict[str, str] = field(default_factory=dict)
    """``logger``, ``bus``, ``gsm`` (the network's HTTP API), ``modem:NUMBER``, ``fleet:N``."""
    names: dict[str, str] = field(default_factory=dict)
    """The control API's name of each device of :attr:`urls` it controls (``fleet:0`` ->
    ``loggers.F0001``)."""
    said: list[str] = field(default_factory=list)
    """What the site announced (a scenario's steps as they ran)."""

    @property
    def control_url(self) -> str:
        """The control API's ``http://127.0.0.1:PORT``."""
        assert self.server is not None
        return f"http://{format_address(*self.server.address)}"

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
        """Let ``seconds`` pass at once (stopping at each scenario step and fault end on the
        way); returns when every device ran what was due."""
        await self.control.apply(Step(seconds))
        now = self.clock.now()
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
        try:
            if self.server is not None:
                await self.server.stop()  # (and the controller)
            else:
                await self.control.close()
        finally:
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
    clock = ControlledClock(1.0)
    said: list[str] = []
    running = await start_site(plan, state, clock, said.append)
    try:
        control = site_control(running, clock, plan.scenario, said.append)
        started = InProcessSite(running, clock, control, said=said)
        started.server = ControlServer(control, "127.0.0.1", 0)
        await started.server.start()
    except BaseException:
        await running.close()
        raise
    urls, names = started.urls, started.names
    names.update({name: name for name in ("logger", "bus", "gsm") if name in control.names()})
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
            names[f"fleet:{index}"] = f"loggers.{member.serial_number}"
    return started


def _tcp(address: tuple[str, int]) -> str:
    return f"tcp://{format_address(*address)}"
