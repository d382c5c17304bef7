"""A logger, its modem and the GSM network on a stepped clock, for the modem driver tests."""

from __future__ import annotations

from typing import ClassVar

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.outbox import Destination, Outbox, Outgoing
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.gsm.gateway import (
    Close,
    Closed,
    Connect,
    Connected,
    IpEffect,
    IpEvent,
    Received,
    Send,
)
from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import Network, PhoneEvent
from sondalog.gsm.system import GsmSystem
from sondalog.protocol.device import Effect, LineSend
from sondalog.world.gsm_site import GsmSite, IpInput, IpRequest, PhoneNotice

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
        self.peers: dict[int, Smtp | Pop3] = {}
        self.mailbox: list[bytes] = []
        self.pop3_delay = 0.0
        self.later: list[tuple[float, int, bytes]] = []

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
                self.serve(e.effect)
            elif isinstance(e, PhoneNotice):
                self.phones.append(e.event)

    def serve(self, effect: IpEffect) -> None:
        """The scripted mail servers behind the IP gateway (SMTP on 25, POP3 on 110)."""
        if isinstance(effect, Connect):
            peer = Smtp() if effect.port == 25 else Pop3(self.mailbox, self.pop3_delay)
            self.peers[effect.conn] = peer
            self.event(Connected(effect.conn))
            self.event(Received(effect.conn, peer.greeting))
        elif isinstance(effect, Send) and effect.conn in self.peers:
            peer = self.peers[effect.conn]
            for answer in peer.feed(effect.data):
                if answer == b"CLOSE":
                    self.event(Closed(effect.conn))
                elif answer.startswith(b"LATER"):
                    self.later.append((self.now + self.pop3_delay, effect.conn, answer[5:]))
                else:
                    self.event(Received(effect.conn, answer))
        elif isinstance(effect, Close):
            self.peers.pop(effect.conn, None)

    def event(self, event: IpEvent) -> None:
        self.collect(self.site.handle(IpInput(event), self.now))

    def run(self, seconds: float) -> None:
        """Step the world through every deadline for ``seconds``."""
        end = self.now + seconds
        self.collect(self.site.advance(self.now))
        for _ in range(100_000):
            due = self.site.next_deadline()
            if due is None or due > end:
                break
            if self.later and self.later[0][0] <= due:
                when, conn, data = self.later.pop(0)
                self.now = max(self.now, when)
                if conn in self.peers:
                    self.event(Received(conn, data))
                continue
            self.now = max(self.now, due)
            self.collect(self.site.advance(self.now))
        self.now = end
        self.collect(self.site.advance(self.now))

    def send(self, body: str, *dests: Destination, subject: str | None = None) -> int:
        ident = self.outbox.new_ident()
        self.outbox.put(Outgoing(ident, 1, tuple(dests), body, subject))
        return ident

    def phone_sms(self, text: str, sender: str = PHONE) -> None:
        call = self.site.network_call
        self.collect(call(lambda n: n.phone_sms(sender, LOGGER, text, self.now), self.now))

    def call(self, kind: str, caller: str = PHONE) -> int:
        call_id, items = self.network.phone_call(caller, LOGGER, kind, self.now)
        self.collect(self.site.network_call(lambda n: items, self.now))
        return call_id

    def phone_data(self, call_id: int, data: bytes) -> None:
        self.collect(self.site.network_call(lambda n: n.phone_data(call_id, data), self.now))

    def sms_to(self, number: str) -> list[str]:
        return [s.text for s in self.network.delivered(number)]

    def modem_saw(self) -> bytes:
        return b"".join(b for d, b in self.trace if d == "rx")


class Smtp:
    """An SMTP server as a script: it takes every message (``mails``)."""

    greeting = b"220 smtp.example.net ESMTP\r\n"
    mails: ClassVar[list[bytes]] = []
    refuse: ClassVar[bool] = False

    def __init__(self) -> None:
        self.buf = b""
        self.data: bytes | None = None

    def feed(self, data: bytes) -> list[bytes]:
        self.buf += data
        out: list[bytes] = []
        while b"\r\n" in self.buf:
            line, self.buf = self.buf.split(b"\r\n", 1)
            if self.data is not None:
                if line == b".":
                    Smtp.mails.append(self.data)
                    self.data = None
                    out.append(b"250 queued\r\n")
                else:
                    self.data += line + b"\r\n"
            elif line.upper().startswith(b"RCPT") and Smtp.refuse:
                out.append(b"550 no such user\r\n")
            elif line.upper().startswith(b"DATA"):
                self.data = b""
                out.append(b"354 go\r\n")
            elif line.upper().startswith(b"QUIT"):
                out += [b"221 bye\r\n", b"CLOSE"]
            else:
                out.append(b"250 ok\r\n")
        return out


class Pop3:
    """A POP3 server as a script over ``mailbox`` (RETR answered after ``delay`` seconds)."""

    greeting = b"+OK POP3 ready\r\n"

    def __init__(self, mailbox: list[bytes], delay: float) -> None:
        self.mailbox = mailbox
        self.delay = delay
        self.buf = b""
        self.deleted = False

    def feed(self, data: bytes) -> list[bytes]:
        self.buf += data
        out: list[bytes] = []
        while b"\r\n" in self.buf:
            line, self.buf = self.buf.split(b"\r\n", 1)
            word = line.split(b" ")[0].upper()
            if word == b"STAT":
                out.append(b"+OK %d %d\r\n" % (len(self.mailbox), sum(map(len, self.mailbox))))
            elif word == b"LIST":
                out.append(b"+OK 1 %d\r\n" % len(self.mailbox[0]))
            elif word == b"RETR":
                body = self.mailbox[0].replace(b"\n.", b"\n..") + b".\r\n"
                answer = b"+OK\r\n" + body
                out.append(b"LATER" + answer if self.delay else answer)
            elif word == b"DELE":
                self.deleted = True
                out.append(b"+OK\r\n")
            elif word == b"QUIT":
                if self.deleted:
                    del self.mailbox[0]
                out += [b"+OK bye\r\n", b"CLOSE"]
            else:
                out.append(b"+OK\r\n")
        return out
