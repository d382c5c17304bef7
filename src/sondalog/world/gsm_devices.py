"""The GSM cores adapted to the :class:`~sondalog.protocol.device.Device` contract, so the one
runtime (:class:`~sondalog.io.host.DeviceHost`) serves them (``docs/gsm.md``, issue 12).

- :class:`ModemDevice`: one Wavecom modem core (:class:`~sondalog.gsm.modem.Modem`); its DTE
  side is every line attached (a pty, TCP connections): bytes from any line go to the modem,
  the modem's answer goes to all of them, as on a serial cable with a Y-splitter. What the
  modem says to the network leaves as :class:`ToNetwork` effects; what the network says to
  it comes in as :class:`FromNetwork` events.
- :class:`NetworkDevice`: the network core (:class:`~sondalog.gsm.network.Network`), a device
  without lines. Modem effects come in as :class:`ModemSaid`, socket events as
  :class:`IpHappened`, the phone side's requests (send an SMS, place a call, coverage...) as
  :class:`Requested`; everything the network says leaves as one effect type,
  :class:`NetworkSaid`, whose typed output the one router
  (:func:`sondalog.gsm.routing.route`) carries on. It also refreshes signal and credit from
  models (functions of time: the site file's signal models) every :data:`MODEL_PERIOD`
  seconds.

Pure: no clock is read, ``now`` comes in with every call.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from sondalog.ala1.pacing import Pacer
from sondalog.gsm import events as ev
from sondalog.gsm.gateway import IpEvent
from sondalog.gsm.modem import Modem, Output
from sondalog.gsm.network import Network
from sondalog.gsm.phones import Request
from sondalog.gsm.routing import NetOutput
from sondalog.protocol.device import Effect, Event, LineSend

#: Seconds between two refreshes of the signal and credit models.
MODEL_PERIOD = 1.0

Model = Callable[[float], float]


@dataclass(frozen=True, slots=True)
class ToNetwork(Effect):
    """Modem ``number`` said ``effect`` to the network."""

    number: str
    effect: ev.Effect


@dataclass(frozen=True, slots=True)
class FromNetwork(Event):
    """The network says ``event`` to this modem."""

    event: ev.Event


@dataclass(frozen=True, slots=True)
class ModemSaid(Event):
    number: str
    effect: ev.Effect


@dataclass(frozen=True, slots=True)
class IpHappened(Event):
    event: IpEvent


@dataclass(frozen=True, slots=True)
class Requested(Event):
    """A request of the phone side; the posting side finds the answer (the ids the network
    gave) among the effects (:class:`~sondalog.gsm.phones.SmsSubmitted`,
    :class:`~sondalog.gsm.phones.CallPlaced`)."""

    request: Request


@dataclass(frozen=True, slots=True)
class NetworkSaid(Effect):
    """One output of the network, for :func:`~sondalog.gsm.routing.route`."""

    output: NetOutput


class ModemDevice:
    """One modem core as a Device: its lines are the DTE side. A paced line carries the
    modem's output at its serial speed (10 bit times a byte, as the logger's com line does)."""

    def __init__(self, number: str, modem: Modem) -> None:
        self.number = number
        self.modem = modem
        self._lines: set[int] = set()
        self._pacers: dict[int, Pacer] = {}
        self._next_line = 1

    def open_line(self, *, paced: bool = False) -> int:
        line = self._next_line
        self._next_line += 1
        self._lines.add(line)
        if paced:
            self._pacers[line] = Pacer(True)
        return line

    def close_line(self, line: int) -> None:
        self._lines.discard(line)
        self._pacers.pop(line, None)

    def line_speed(self) -> int:
        return self.modem.speed

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        return self._effects(self.modem.receive(data, now), now)

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        if isinstance(event, FromNetwork):
            return self._effects(self.modem.event(event.event, now), now)
        return []

    def advance(self, now: float) -> Sequence[Effect]:
        return self._effects(self.modem.advance(now), now)

    def next_deadline(self) -> float | None:
        deadlines = [d for p in self._pacers.values() if (d := p.next_deadline()) is not None]
        modem = self.modem.next_deadline()
        if modem is not None:
            deadlines.append(modem)
        return min(deadlines, default=None)

    def output(self, data: bytes, now: float) -> list[Effect]:
        """``data`` for every line: at once, or paced on a paced line."""
        effects: list[Effect] = []
        for line in sorted(self._lines):
            pacer = self._pacers.get(line)
            if pacer is None:
                if data:
                    effects.append(LineSend(line, data))
                continue
            if data:
                pacer.push(data, self.modem.speed, now)
            effects += [LineSend(line, piece, baud) for piece, baud in pacer.take(now)]
        return effects

    def _effects(self, out: Output, now: float) -> list[Effect]:
        effects = self.output(out.data, now)
        effects += [ToNetwork(self.number, effect) for effect in out.effects]
        return effects


def said(outputs: Iterable[NetOutput]) -> list[Effect]:
    """What a :class:`Network` method returned, as effects for the runtime."""
    return [NetworkSaid(output) for output in outputs]


class NetworkDevice:
    """The network core as a Device without lines."""

    def __init__(
        self,
        network: Network,
        now: float,
        signals: dict[str, Model] | None = None,
        credits: dict[str, Model] | None = None,
    ) -> None:
        self.network = network
        self.now = now
        self.signals = signals or {}
        self.credits = credits or {}
        self._spent: dict[str, float] = {}  # credit taken by the network beside a model
        self._set: dict[str, float] = {}
        self._next_model: float | None = now if (self.signals or self.credits) else None

    def open_line(self, *, paced: bool = False) -> int:
        raise ValueError("the network has no lines; its modems have")

    def close_line(self, line: int) -> None:
        return None

    def line_speed(self) -> int:
        return 9600

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        return []

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        self.now = max(self.now, now)
        if isinstance(event, ModemSaid):
            return said(self.network.from_modem(event.number, event.effect, now))
        if isinstance(event, IpHappened):
            return said(self.network.ip_event(event.event, now))
        if isinstance(event, Requested):
            return said(self.network.request(event.request, now))
        return []

    def advance(self, now: float) -> Sequence[Effect]:
        self.now = max(self.now, now)
        out = said(self.network.advance(now))
        if self._next_model is not None and now >= self._next_model:
            out += self.refresh_models(now)
            self._next_model = now + MODEL_PERIOD
        return out

    def next_deadline(self) -> float | None:
        times = [self.network.next_deadline(self.now), self._next_model]
        present = [t for t in times if t is not None]
        return min(present) if present else None

    def refresh_models(self, now: float) -> list[Effect]:
        """Signal and credit from their models at ``now`` (a Signal event only on change)."""
        out: list[Effect] = []
        for number, model in self.signals.items():
            rssi = max(0, min(31, round(model(now))))
            if self.network.subscriber(number).rssi != rssi:
                out += said(self.network.set_signal(number, rssi, now))
        for number, model in self.credits.items():
            sub = self.network.subscriber(number)
            if number in self._set:
                self._spent[number] = self._spent.get(number, 0.0) + self._set[number] - sub.credit
            value = round(model(now) - self._spent.get(number, 0.0), 2)
            self.network.set_credit(number, value)
            self._set[number] = value
        return out
