"""One ALA1 logger, its Wavecom modem and the GSM network, composed purely (gsm.md §1).

:class:`GsmSite` is a :class:`~sondalog.protocol.device.Device`: its lines are the logger's
cable lines (the virtual device's convenience beside the modem); the logger's com line is
wired to the modem's DTE side inside (``Engine.attach_modem``), so every AT byte the logger
writes reaches the modem and every answer comes back, until nothing moves. What leaves the
world comes out as effects: :class:`IpRequest` (the network's IP gateway asks the runtime to
connect, send, close, listen) and :class:`PhoneNotice` (an SMS or call event for a phone).
The runtime answers with :class:`IpInput` events. Tests drive it on a stepped clock.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

from sondalog.ala1.engine import Engine
from sondalog.gsm.gateway import IpEffect, IpEvent
from sondalog.gsm.modem import Modem
from sondalog.gsm.network import Network
from sondalog.gsm.phones import PhoneEvent
from sondalog.gsm.routing import NetOutput
from sondalog.gsm.system import GsmSystem, SystemOutput
from sondalog.protocol.device import Effect, Event, LineSend

#: Rounds of logger <-> modem exchange in one call (a guard against a loop that never ends).
MAX_ROUNDS = 1000


@dataclass(frozen=True, slots=True)
class IpRequest(Effect):
    effect: IpEffect


@dataclass(frozen=True, slots=True)
class PhoneNotice(Effect):
    event: PhoneEvent


@dataclass(frozen=True, slots=True)
class IpInput(Event):
    event: IpEvent


#: A modem-line tap for ``--trace``: (direction "rx" logger>modem / "tx", bytes, now).
Tap = Callable[[str, bytes, float], None]


class GsmSite:
    """A logger with its modem (subscriber ``number``) in a network."""

    def __init__(
        self, engine: Engine, modem: Modem, system: GsmSystem, number: str, now: float
    ) -> None:
        self.engine = engine
        self.modem = modem
        self.system = system
        self.number = number
        self.tap: Tap | None = None
        self.modem_line = engine.attach_modem(now)
        self._pending = self._settle(system.add_modem(number, modem, now), now, [])

    @property
    def network(self) -> Network:
        return self.system.network

    # -- Device --------------------------------------------------------------------------
    def open_line(self, *, paced: bool = False) -> int:
        return self.engine.open_line(paced=paced)

    def close_line(self, line: int) -> None:
        self.engine.close_line(line)

    def line_speed(self) -> int:
        return self.engine.line_speed()

    def receive(self, line: int, data: bytes, now: float) -> list[Effect]:
        return self._engine_out(self.engine.receive(line, data, now), now)

    def handle(self, event: Event, now: float) -> list[Effect]:
        if isinstance(event, IpInput):
            return self._run(self.system.ip_event(event.event, now), now)
        return self._engine_out(self.engine.handle(event, now), now)

    def advance(self, now: float) -> list[Effect]:
        out = self._take_pending()
        out += self._run(self.system.advance(now), now)
        return out + self._engine_out(self.engine.advance(now), now)

    def next_deadline(self) -> float | None:
        times = [self.engine.next_deadline()]
        now = min((t for t in times if t is not None), default=0.0)
        times.append(self.system.next_deadline(now))
        if self._pending:
            times.append(now)
        return min((t for t in times if t is not None), default=None)

    # -- the network's side, for the runtime ------------------------------------------
    def network_call(
        self, call: Callable[[Network], Iterable[NetOutput]], now: float
    ) -> list[Effect]:
        """Run a :class:`Network` method (``phone_sms``, ``set_coverage``...) and route it."""
        return self._run(self.system.network_call(call(self.network), now), now)

    # -- wiring ----------------------------------------------------------------------------
    def _take_pending(self) -> list[Effect]:
        out, self._pending = self._pending, []
        return out

    def _run(self, sysout: SystemOutput, now: float) -> list[Effect]:
        return self._take_pending() + self._settle(sysout, now, [])

    def _engine_out(self, sends: list[LineSend], now: float) -> list[Effect]:
        out: list[Effect] = self._take_pending()
        to_modem = b""
        for send in sends:
            if send.line == self.modem_line:
                to_modem += send.data
            else:
                out.append(send)
        if to_modem:
            self._trace("rx", to_modem, now)
            out += self._settle(self.system.modem_input(self.number, to_modem, now), now, [])
        return out

    def _settle(self, sysout: SystemOutput, now: float, out: list[Effect]) -> list[Effect]:
        for _ in range(MAX_ROUNDS):
            out += [IpRequest(e) for e in sysout.ip] + [PhoneNotice(p) for p in sysout.phones]
            data = sysout.line(self.number)
            if not data:
                return out
            self._trace("tx", data, now)
            sends = self.engine.receive(self.modem_line, data, now)
            to_modem = b""
            for send in sends:
                if send.line == self.modem_line:
                    to_modem += send.data
                else:
                    out.append(send)
            if not to_modem:
                return out
            self._trace("rx", to_modem, now)
            sysout = self.system.modem_input(self.number, to_modem, now)
        raise RuntimeError("the logger and its modem never stop talking")

    def _trace(self, direction: str, data: bytes, now: float) -> None:
        if self.tap is not None:
            self.tap(direction, data, now)
