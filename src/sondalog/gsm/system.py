"""Modems and the network composed, still pure: what the runtime (or a test) drives.

:class:`GsmSystem` carries each modem's effects to the network and the network's events to
the modems until nothing moves, and hands back what leaves the system: bytes for each modem's
serial line, events for phones, socket effects for the IP gateway.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.gsm.gateway import IpEffect, IpEvent, ModemEvent
from sondalog.gsm.modem import Modem, Output
from sondalog.gsm.network import Network, PhoneEvent


@dataclass(slots=True)
class SystemOutput:
    lines: dict[str, bytes] = field(default_factory=dict)
    phones: list[PhoneEvent] = field(default_factory=list)
    ip: list[IpEffect] = field(default_factory=list)

    def line(self, number: str) -> bytes:
        return self.lines.get(number, b"")


class GsmSystem:
    """A network and the modems of its modem subscribers."""

    def __init__(self, network: Network | None = None) -> None:
        self.network = network or Network()
        self.modems: dict[str, Modem] = {}

    def add_modem(self, number: str, modem: Modem, now: float, **kw: object) -> SystemOutput:
        self.modems[number] = modem
        return self._run(self.network.add_modem(number, now, **kw), now)

    def modem_input(self, number: str, data: bytes, now: float) -> SystemOutput:
        """Bytes the DTE wrote on modem ``number``'s serial line."""
        out = SystemOutput()
        self._modem_output(number, self.modems[number].receive(data, now), out, now)
        return out

    def advance(self, now: float) -> SystemOutput:
        out = SystemOutput()
        for number, modem in self.modems.items():
            self._modem_output(number, modem.advance(now), out, now)
        return self._run(self.network.advance(now), now, out)

    def next_deadline(self, now: float) -> float | None:
        times = [m.next_deadline() for m in self.modems.values()]
        times.append(self.network.next_deadline(now))
        present = [t for t in times if t is not None]
        return min(present) if present else None

    def network_call(self, items: list[object], now: float) -> SystemOutput:
        """Route what a :class:`Network` method returned (``phone_sms``, ``set_signal``...)."""
        return self._run(items, now)

    def ip_event(self, event: IpEvent, now: float) -> SystemOutput:
        return self._run(self.network.ip_event(event, now), now)

    def _modem_output(self, number: str, output: Output, out: SystemOutput, now: float) -> None:
        self._run(self._take(number, output, out, now), now, out)

    def _take(self, number: str, output: Output, out: SystemOutput, now: float) -> list[object]:
        """Modem ``number``'s line bytes into ``out``; what its effects make the network do."""
        if output.data:
            out.lines[number] = out.lines.get(number, b"") + output.data
        items: list[object] = []
        for effect in output.effects:
            items += self.network.from_modem(number, effect, now)
        return items

    def _run(
        self, items: list[object], now: float, out: SystemOutput | None = None
    ) -> SystemOutput:
        out = out if out is not None else SystemOutput()
        pending = list(items)
        while pending:
            item = pending.pop(0)
            if isinstance(item, ModemEvent):
                modem = self.modems.get(item.number)
                if modem is None:
                    continue
                pending += self._take(item.number, modem.event(item.event, now), out, now)
            elif isinstance(item, PhoneEvent):
                out.phones.append(item)
            else:
                out.ip.append(item)  # type: ignore[arg-type]
        return out
