"""Modems and the network composed, still pure: what the runtime (or a test) drives.

:class:`GsmSystem` carries each modem's effects to the network and the network's output to
the modems until nothing moves, and hands back what leaves the system: bytes for each modem's
serial line, events for phones, the answers to the phone side's requests, socket effects for
the IP gateway. The network's output goes through the one router
(:func:`sondalog.gsm.routing.route`), as in the served world (:mod:`sondalog.app.gsm`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field

from sondalog.gsm import events as ev
from sondalog.gsm.gateway import IpEffect, IpEvent
from sondalog.gsm.modem import Modem, Output
from sondalog.gsm.network import Network
from sondalog.gsm.phones import CallPlaced, PhoneEvent, Request, SmsSubmitted
from sondalog.gsm.routing import NetOutput, route


@dataclass(slots=True)
class SystemOutput:
    lines: dict[str, bytes] = field(default_factory=dict)
    phones: list[PhoneEvent] = field(default_factory=list)
    ip: list[IpEffect] = field(default_factory=list)
    submitted: list[SmsSubmitted] = field(default_factory=list)
    placed: list[CallPlaced] = field(default_factory=list)

    def line(self, number: str) -> bytes:
        return self.lines.get(number, b"")


class GsmSystem:
    """A network and the modems of its modem subscribers."""

    def __init__(self, network: Network | None = None) -> None:
        self.network = network or Network()
        self.modems: dict[str, Modem] = {}

    def add_modem(self, number: str, modem: Modem, now: float, **kw: object) -> SystemOutput:
        self.modems[number] = modem
        return self.network_call(self.network.add_modem(number, now, **kw), now)

    def modem_input(self, number: str, data: bytes, now: float) -> SystemOutput:
        """Bytes the DTE wrote on modem ``number``'s serial line."""
        run = _Run(self, now)
        run.modem_said(number, self.modems[number].receive(data, now))
        return run.finish()

    def advance(self, now: float) -> SystemOutput:
        run = _Run(self, now)
        for number, modem in self.modems.items():
            run.modem_said(number, modem.advance(now))
            run.settle()
        run.pending.extend(self.network.advance(now))
        return run.finish()

    def next_deadline(self, now: float) -> float | None:
        times = [m.next_deadline() for m in self.modems.values()]
        times.append(self.network.next_deadline(now))
        present = [t for t in times if t is not None]
        return min(present) if present else None

    def request(self, request: Request, now: float) -> SystemOutput:
        """A request of the phone side (send an SMS, place a call, coverage...)."""
        return self.network_call(self.network.request(request, now), now)

    def network_call(self, items: Iterable[NetOutput], now: float) -> SystemOutput:
        """Route what a :class:`Network` method returned (``phone_sms``, ``set_signal``...)."""
        run = _Run(self, now)
        run.pending.extend(items)
        return run.finish()

    def ip_event(self, event: IpEvent, now: float) -> SystemOutput:
        return self.network_call(self.network.ip_event(event, now), now)


class _Run:
    """One pass of the pure composition, its :class:`~sondalog.gsm.routing.Destinations`:
    an event for a modem goes to the modem core at once and what its effects make the network
    say waits its turn (first in, first out); everything else is collected in ``out``."""

    def __init__(self, system: GsmSystem, now: float) -> None:
        self.system = system
        self.now = now
        self.out = SystemOutput()
        self.pending: deque[NetOutput] = deque()

    def settle(self) -> None:
        """Route until nothing moves."""
        while self.pending:
            route((self.pending.popleft(),), self)

    def finish(self) -> SystemOutput:
        self.settle()
        return self.out

    def modem_said(self, number: str, output: Output) -> None:
        """Modem ``number``'s line bytes into ``out``; what its effects make the network say
        into the queue."""
        if output.data:
            self.out.lines[number] = self.out.lines.get(number, b"") + output.data
        for effect in output.effects:
            self.pending.extend(self.system.network.from_modem(number, effect, self.now))

    # -- Destinations ----------------------------------------------------------------------
    def to_modem(self, number: str, event: ev.Event) -> None:
        modem = self.system.modems.get(number)
        if modem is not None:
            self.modem_said(number, modem.event(event, self.now))

    def to_phone(self, event: PhoneEvent) -> None:
        self.out.phones.append(event)

    def to_ip(self, effect: IpEffect) -> None:
        self.out.ip.append(effect)

    def sms_submitted(self, reply: SmsSubmitted) -> None:
        self.out.submitted.append(reply)

    def call_placed(self, reply: CallPlaced) -> None:
        self.out.placed.append(reply)
