"""The control of a served site (issue 23): its devices, their faults, its clock.

A :class:`Controller` is made over what :func:`sondalog.app.serve.start_site` started and
applies the actions of :mod:`sondalog.app.control_actions` to it (:meth:`Controller.apply`);
the HTTP API (:mod:`sondalog.app.control_api`) and a site file's scenario
(:mod:`sondalog.app.scenario_run`, a :class:`Scheduled` of :attr:`Controller.scheduled`) drive it.
A step of the clock stops at every moment something is due on the way (a scenario's step, a
fault's end) and lets the devices catch up there first, so what they sample in between sees it.

Devices are named: ``logger`` (the site's ``[logger]``), ``loggers.SERIAL`` (a member of its
``[[loggers]]`` fleet), ``gsm`` (the GSM network), ``mail`` (the mail hub). A fault given a
``duration`` ends by itself when the site's clock has run that long (a step counts); time
actions need the clock of ``serve --control`` (:class:`~sondalog.io.clock_control.ControlledClock`).
Nothing is changed by an action that is refused (:class:`~sondalog.app.control_logger.Refusal`):
everything is checked first.
"""

from __future__ import annotations

import asyncio
import contextlib
from datetime import UTC, datetime
from typing import Any, Protocol

from sondalog.app.control_actions import (
    INPUT_FAULTS,
    Action,
    Clear,
    Fault,
    Pause,
    Restart,
    Restore,
    Resume,
    SetInput,
    Snapshot,
    Speed,
    Step,
)
from sondalog.app.control_bus import ControlledBus
from sondalog.app.control_logger import (
    RESET_VOLTS,
    ActiveFault,
    ControlledLogger,
    Refusal,
    fault_json,
    logger_json,
    resolve_channel,
)
from sondalog.app.fleet import NamedDevice
from sondalog.app.serve import RunningSite
from sondalog.backends.sim.signals import constant
from sondalog.backends.store.ala1_nv import LoggerNvStore
from sondalog.gsm.sms import normalize
from sondalog.io.clock import Clock
from sondalog.io.clock_control import ControlledClock

#: The most snapshots a logger keeps (each holds up to its whole memory, 1 MiB).
MAX_SNAPSHOTS = 16
#: Event-loop turns a step waits at most for the devices to run what fell due.
_SETTLE_TURNS = 1000


class Scheduled(Protocol):
    """What runs at moments of the site's clock (a scenario)."""

    def next_due(self) -> float | None: ...

    async def run_due(self) -> None: ...

    async def close(self) -> None: ...


class Controller:
    """The devices of a running site and the actions applied to them."""

    def __init__(self, site: RunningSite, clock: Clock) -> None:
        self.site = site
        self.clock = clock
        self.loggers: dict[str, ControlledLogger] = {}
        if site.logger is not None:
            self.loggers["logger"] = ControlledLogger("logger", site.logger.host, site.logger.store)
        if site.fleet is not None:
            for member in site.fleet.members:
                store, named = member.engine.state.store, member.host.device
                assert isinstance(store, LoggerNvStore) and isinstance(named, NamedDevice)
                name = f"loggers.{member.serial_number}"
                self.loggers[name] = ControlledLogger(name, member.host, store, named)
        self.bus = ControlledBus(site.bus.core) if site.bus is not None else None
        self.gsm_faults: dict[str | None, ActiveFault] = {}
        self.mail_fault: ActiveFault | None = None
        self._timer: asyncio.Task[None] | None = None
        self._rearm = asyncio.Event()
        self.scheduled: list[Scheduled] = []

    # -- what there is -----------------------------------------------------------------------
    def names(self) -> list[str]:
        names = list(self.loggers) + (["bus"] if self.bus is not None else [])
        if self.site.gsm is not None:
            names.append("gsm")
        if self.site.mail is not None:
            names.append("mail")
        return names

    def logger(self, name: str) -> ControlledLogger:
        found = self.loggers.get(name)
        if found is None:
            if self.is_device(name):
                raise Refusal(409, f"{name} is not a logger", "device")
            names = self.names()
            shown = ", ".join(names[:8]) + (f" and {len(names) - 8} more" if len(names) > 8 else "")
            raise Refusal(404, f"no device {name[:40]!r} (devices: {shown})", "device")
        return found

    def is_device(self, name: str) -> bool:
        return (
            name in self.loggers
            or (name == "bus" and self.bus is not None)
            or (name == "gsm" and self.site.gsm is not None)
            or (name == "mail" and self.site.mail is not None)
        )

    def devices(self) -> list[dict[str, Any]]:
        out = [logger_json(name, logger) for name, logger in self.loggers.items()]
        out += [self.bus.json()] if self.bus is not None else []
        out += [self._other_json(name) for name in ("gsm", "mail") if self.is_device(name)]
        return out

    def _other_json(self, name: str) -> dict[str, Any]:
        """The network or the mail hub."""
        if name == "gsm":
            faults = [fault_json(a) for a in self.gsm_faults.values()]
        else:
            faults = [fault_json(self.mail_fault)] if self.mail_fault is not None else []
        return {"name": name, "kind": name, "faults": faults}

    def describe(self, name: str) -> dict[str, Any]:
        if name == "bus" and self.bus is not None:
            return self.bus.describe(self.clock.now())
        if name not in self.loggers and self.is_device(name):
            return self._other_json(name)
        logger = self.logger(name)
        now = self.clock.now()
        state = logger.engine.state
        return {
            **logger_json(name, logger),
            "module_time": state.module_time(now).isoformat(),
            "record_rows": len(state.record),
            "restarts": logger.restarts,
            "inputs": logger.inputs(now),
            "snapshots": list(logger.snapshots),
        }

    def time(self) -> dict[str, Any]:
        now, clock = self.clock.now(), self.clock
        controlled = isinstance(clock, ControlledClock)
        return {
            "now": now,
            "iso": datetime.fromtimestamp(now, tz=UTC).isoformat(),
            "paused": clock.paused if isinstance(clock, ControlledClock) else False,
            "speed": clock.rate if isinstance(clock, ControlledClock) else clock.speed,
            "controlled": controlled,
        }

    # -- acting ------------------------------------------------------------------------------
    async def apply(self, action: Action) -> dict[str, Any]:
        """Apply ``action``; its answer (JSON). Raises :class:`Refusal` (nothing applied)."""
        now = self.clock.now()
        if (logger := self.loggers.get(getattr(action, "device", ""))) is not None:
            action = resolve_channel(logger, action)  # (ch2: the input channel 2 reads)
        match action:
            case Pause() | Resume() | Speed() | Step():
                return await self._time(action)
            case SetInput() if action.device == "bus" and self.bus is not None:
                return self.bus.set(action, now)
            case SetInput():
                logger = self.logger(action.device)
                logger.set_input(action, now)
                return {
                    "device": action.device,
                    "input": action.input,
                    "value": logger.inputs(now).get(action.input),
                }
            case Fault():
                return self._fault(action, now)
            case Clear():
                cleared = self._clear(action, now)
                return {"device": action.device, "cleared": cleared}
            case Restart():
                logger = self.logger(action.device)
                if logger.off:
                    raise Refusal(409, f"{action.device} has no power: clear the fault first")
                logger.restart(now)
                return {"device": action.device, "restarts": logger.restarts}
            case Snapshot():
                logger = self.logger(action.device)
                if action.name not in logger.snapshots and len(logger.snapshots) >= MAX_SNAPSHOTS:
                    raise Refusal(
                        409,
                        f"{action.device} keeps {MAX_SNAPSHOTS} snapshots at most: reuse a name",
                        "name",
                    )
                state = logger.snapshot(action.name)
                return {"device": action.device, "snapshot": action.name, "record_rows": state.rows}
            case Restore():
                logger = self.logger(action.device)
                logger.check_restorable(action.name)  # (before any fault ends)
                for key in list(logger.faults):
                    self._end(logger, key, now)
                state = logger.restore(action.name, now)
                return {"device": action.device, "restored": action.name, "record_rows": state.rows}
        raise AssertionError(action)

    async def _time(self, action: Pause | Resume | Speed | Step) -> dict[str, Any]:
        clock = self.clock
        if not isinstance(clock, ControlledClock):
            raise Refusal(409, "the site's clock is not controlled: serve it with --control")
        if isinstance(action, Pause):
            clock.pause()
        elif isinstance(action, Resume):
            clock.resume()
        elif isinstance(action, Speed):
            clock.set_rate(action.factor)
        else:
            target = clock.now() + action.seconds
            while (due := self._next_due()) is not None and due <= target:
                clock.advance_to(due)  # (exactly there: a step's own moment)
                await self._catch_up()
            clock.advance_to(target)
            await self._catch_up()
        self._rearm.set()
        return self.time()

    def _next_due(self) -> float | None:
        dues = [s.next_due() for s in self.scheduled]
        return min((d for d in [self._next_end(), *dues] if d is not None), default=None)

    async def _catch_up(self) -> None:
        await self.settle()
        self._end_due(self.clock.now())
        for scheduled in self.scheduled:
            await scheduled.run_due()

    async def settle(self) -> None:
        """Let every logger (and the bus) run what is due now (after a step)."""
        hosts = [logger.host for logger in self.loggers.values()]
        hosts += [self.site.bus.host] if self.site.bus is not None else []
        for _ in range(_SETTLE_TURNS):
            now = self.clock.now()
            if all((d := h.device.next_deadline()) is None or d > now for h in hosts):
                return
            await asyncio.sleep(0)

    def _fault(self, fault: Fault, now: float) -> dict[str, Any]:
        if fault.device == "bus" and self.bus is not None:
            answer = self.bus.fault(fault, now)
            self._timers()
            return answer
        if fault.device == "gsm":
            return self._gsm_fault(fault, now)
        if fault.device == "mail":
            return self._mail_fault(fault, now)
        if fault.kind in ("no_coverage", "smtp_refusing"):
            owner = "gsm" if fault.kind == "no_coverage" else "mail"
            raise Refusal(400, f"a {fault.kind} fault is the {owner} device's", "kind")
        logger = self.logger(fault.device)
        key = (fault.kind, fault.input)
        if key in logger.faults:
            raise Refusal(
                409, f"{fault.device} already has this {fault.kind} fault: clear it first", "kind"
            )
        until = None if fault.duration is None else now + fault.duration
        active = ActiveFault(fault, until)
        if fault.kind in INPUT_FAULTS:
            active.undo = logger.fault_input(fault, now)
        elif fault.kind == "clock_jump":
            logger.jump_clock(fault.seconds or 0.0, now)
            return {
                "device": fault.device,
                "fault": fault_json(active),
                "module_time": logger.engine.state.module_time(now).isoformat(),
            }
        elif fault.kind in ("noise", "cut", "slow"):
            logger.fault_line(fault)
        elif fault.kind == "brownout":
            sim = logger.hardware("a brown-out")
            active.undo = sim.supply_signal
            sim.supply_signal = constant(fault.volts or 0.0)
        logger.faults[key] = active
        self._power(logger, now)
        self._timers()
        return {"device": fault.device, "fault": fault_json(active), "powered": not logger.off}

    def _gsm_fault(self, fault: Fault, now: float) -> dict[str, Any]:
        gsm = self.site.gsm
        if gsm is None:
            raise Refusal(404, "no device 'gsm': the site has no [gsm]", "device")
        if fault.kind != "no_coverage":
            raise Refusal(
                400, f"the gsm device has no {fault.kind} fault (it has no_coverage)", "kind"
            )
        number = None if fault.number is None else normalize(fault.number)
        if number is not None and number not in gsm.network.subscribers:
            raise Refusal(404, f"{number} is not a subscriber of the network", "number")
        if number in self.gsm_faults:
            raise Refusal(409, "this coverage fault is active: clear it first", "number")
        gsm.set_coverage(number, False)
        active = ActiveFault(fault, None if fault.duration is None else now + fault.duration)
        self.gsm_faults[number] = active
        self._timers()
        return {"device": "gsm", "fault": fault_json(active)}

    def _mail_fault(self, fault: Fault, now: float) -> dict[str, Any]:
        mail = self.site.mail
        if mail is None:
            raise Refusal(404, "no device 'mail': the site has no [mail]", "device")
        if fault.kind != "smtp_refusing":
            raise Refusal(
                400, f"the mail device has no {fault.kind} fault (it has smtp_refusing)", "kind"
            )
        if self.mail_fault is not None:
            raise Refusal(409, "the SMTP server refuses already: clear it first", "kind")
        code = fault.code or 451
        text = "4.3.2 try again later" if code < 500 else "5.7.1 refused"
        mail.accounts.refusal = f"{code} {text} (sondalog control API)"
        self.mail_fault = ActiveFault(
            fault, None if fault.duration is None else now + fault.duration
        )
        self._timers()
        return {"device": "mail", "fault": fault_json(self.mail_fault)}

    def _end_mail(self) -> None:
        self.mail_fault = None
        if self.site.mail is not None:
            self.site.mail.accounts.refusal = None

    def _clear(self, clear: Clear, now: float) -> list[dict[str, Any]]:
        if clear.device == "bus" and self.bus is not None:
            return self.bus.clear(clear)
        if clear.device == "mail" and self.site.mail is not None:
            active = self.mail_fault
            if active is None or clear.kind not in (None, "smtp_refusing"):
                return []
            self._end_mail()
            return [fault_json(active)]
        if clear.device == "gsm" and self.site.gsm is not None:
            cleared = [
                fault_json(a)
                for a in self.gsm_faults.values()
                if clear.kind in (None, "no_coverage")
            ]
            if clear.kind in (None, "no_coverage"):
                for number in list(self.gsm_faults):
                    self._end_gsm(number)
            return cleared
        logger = self.logger(clear.device)
        if clear.input is not None:
            logger.check_input(clear.input)
        keys = [
            key
            for key in logger.faults
            if clear.kind in (None, key[0]) and clear.input in (None, key[1])
        ]
        cleared = [fault_json(logger.faults[key]) for key in keys]
        for key in keys:
            self._end(logger, key, now)
        return cleared

    def _end(self, logger: ControlledLogger, key: tuple[str, str | None], now: float) -> None:
        active = logger.faults.pop(key)
        kind = active.fault.kind
        if kind in INPUT_FAULTS:
            logger.clear_input(active)
        elif kind in ("noise", "cut", "slow"):
            logger.clear_line(kind)
        elif kind == "brownout":
            sim = logger.sim
            if sim is not None:
                sim.supply_signal = active.undo
        self._power(logger, now)

    def _end_gsm(self, number: str | None) -> None:
        self.gsm_faults.pop(number, None)
        if self.site.gsm is not None:
            self.site.gsm.set_coverage(number, True)

    def _power(self, logger: ControlledLogger, now: float) -> None:
        """Off while a power loss or a brown-out below the reset voltage lasts; on (a
        restart from the memory) once none does."""
        off = any(
            a.fault.kind == "power_loss"
            or (a.fault.kind == "brownout" and (a.fault.volts or 0.0) < RESET_VOLTS)
            for a in logger.faults.values()
        )
        if off and not logger.off:
            logger.power_off()
        elif logger.off and not off:
            logger.power_on(now)

    # -- faults that end by themselves -------------------------------------------------------
    def _timers(self) -> None:
        if self._timer is None:
            self._timer = asyncio.get_running_loop().create_task(self._expire())
        self._rearm.set()

    def _next_end(self) -> float | None:
        ends = [
            a.until
            for lg in self.loggers.values()
            for a in lg.faults.values()
            if a.until is not None
        ]
        ends += [a.until for a in self.gsm_faults.values() if a.until is not None]
        ends += [a.until for a in self.bus.faults.values() if a.until] if self.bus else []
        if self.mail_fault is not None and self.mail_fault.until is not None:
            ends.append(self.mail_fault.until)
        return min(ends, default=None)

    async def _expire(self) -> None:
        while True:
            self._rearm.clear()
            deadline = self._next_end()
            waits: list[asyncio.Future[Any]] = [asyncio.ensure_future(self._rearm.wait())]
            if deadline is not None:
                waits.append(asyncio.ensure_future(self.clock.sleep_until(deadline)))
            try:
                await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
            finally:
                for task in waits:
                    task.cancel()
                await asyncio.gather(*waits, return_exceptions=True)
            self._end_due(self.clock.now())

    def _end_due(self, now: float) -> None:
        """End every fault whose duration ran out by ``now``."""
        for logger in self.loggers.values():
            for key, active in list(logger.faults.items()):
                if active.until is not None and active.until <= now:
                    self._end(logger, key, now)
        for number, active in list(self.gsm_faults.items()):
            if active.until is not None and active.until <= now:
                self._end_gsm(number)
        bus = self.bus
        for key, active in list(bus.faults.items()) if bus is not None else []:
            if bus is not None and active.until is not None and active.until <= now:
                bus.end(key)
        mail = self.mail_fault
        if mail is not None and mail.until is not None and mail.until <= now:
            self._end_mail()

    async def close(self) -> None:
        for scheduled in self.scheduled:
            await scheduled.close()
        if self._timer is not None:
            self._timer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._timer
