"""A logger, its modem and the GSM network on a stepped clock, for the modem driver tests."""

from __future__ import annotations

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.outbox import Destination, Outbox, Outgoing
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.gsm.gateway import IpEffect
from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import Network, PhoneEvent
from sondalog.gsm.system import GsmSystem
from sondalog.protocol.device import Effect, LineSend
from sondalog.world.gsm_site import GsmSite, IpRequest, PhoneNotice

LOGGER = "+420600000001"
PHONE = "+420700000001"
PHONE2 = "+420700000002"
T0 = 1_764_464_400.0


class World:
    def __init__(self, device: str = "wavecom41", *settings: str) -> None:
        self.now = T0
        self.store = SqliteNvStore(":memory:")
        self.engine = Engine(Identity(Version.V2_10), self.store, self.now)
        self.cable = self.engine.open_line()
        for command in (f"write com device {device}", *settings):
            self.ask(command)
        self.network = Network()
        self.network.add_phone(PHONE)
        self.network.add_phone(PHONE2)
        self.modem = Modem(ModemConfig())
        self.trace: list[tuple[str, bytes]] = []
        self.site = GsmSite(self.engine, self.modem, GsmSystem(self.network), LOGGER, self.now)
        self.site.tap = lambda d, b, t: self.trace.append((d, b))
        assert self.engine.modem is not None
        self.link = self.engine.modem
        self.driver = self.link.driver
        self.outbox: Outbox = self.link.outbox
        self.done: list[tuple[int, bool]] = []
        self.outbox.on_done(lambda i, ok: self.done.append((i, ok)))
        self.cable_out = b""
        self.ip: list[IpEffect] = []
        self.phones: list[PhoneEvent] = []

    def ask(self, command: str) -> bytes:
        out = self.engine.receive(self.cable, command.encode() + b"\r", self.now)
        data = b"".join(o.data for o in out if o.line == self.cable)
        assert data.endswith(b"OK\r\n"), (command, data)
        return data

    def collect(self, effects: list[Effect]) -> None:
        for e in effects:
            if isinstance(e, LineSend):
                self.cable_out += e.data
            elif isinstance(e, IpRequest):
                self.ip.append(e.effect)
            elif isinstance(e, PhoneNotice):
                self.phones.append(e.event)

    def run(self, seconds: float) -> None:
        """Step the world through every deadline for ``seconds``."""
        end = self.now + seconds
        self.collect(self.site.advance(self.now))
        for _ in range(100_000):
            due = self.site.next_deadline()
            if due is None or due > end:
                break
            self.now = max(self.now, due)
            self.collect(self.site.advance(self.now))
        self.now = end
        self.collect(self.site.advance(self.now))

    def send(self, body: str, *dests: Destination, subject: str | None = None) -> int:
        ident = self.outbox.new_ident()
        self.outbox.put(Outgoing(ident, 1, tuple(dests), body, subject))
        return ident

    def phone_sms(self, text: str, sender: str = PHONE) -> None:
        self.collect(self.site.network_call(lambda n: n.phone_sms(sender, LOGGER, text, self.now), self.now))

    def sms_to(self, number: str) -> list[str]:
        return [s.text for s in self.network.delivered(number)]

    def modem_saw(self) -> bytes:
        return b"".join(b for d, b in self.trace if d == "rx")
