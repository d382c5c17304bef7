"""A logger, its modem and the GSM network on a stepped clock, with a modem line that is
slow and cuts its bytes where it likes: the world of the liveness tests (gsm.md §7).

Unlike :mod:`gsm_world` (which hands every answer over at once, whole), the wire between the
logger's com line and the modem delays each chunk by the current :attr:`LiveWorld.latency`
and cuts it at the points :attr:`LiveWorld.cuts` gives, in order both ways: answers come late
and in pieces, as on a real serial line to a busy modem. Everything else is the real thing:
the ALA1 engine with its modem driver, the Wavecom modem core, the network core, and
scripted SMTP/POP3 servers behind the IP gateway (:mod:`gsm_world`).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from gsm_world import Pop3, Smtp

from sondalog.ala1 import Engine, Identity, Version
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.gsm import gateway as gw
from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import Network, PhoneEvent
from sondalog.gsm.system import GsmSystem, SystemOutput
from sondalog.protocol.device import LineSend

LOGGER = "+420600000001"
T0 = 1_764_464_400.0
#: An AT command line at the start of a chunk or after a line end (never sent in data mode).
AT_LINE = re.compile(rb"(?:^|[\r\n])AT[A-Z+&]")


class LiveWorld:
    def __init__(self, device: str = "wavecom41", *settings: str, phones: int = 4) -> None:
        self.now = T0
        self.engine = Engine(Identity(Version.V2_10), SqliteNvStore(":memory:"), self.now)
        self.cable = self.engine.open_line()
        self.cable_out = b""
        self.line = -1  # the modem line, once attached
        for command in (f"write com device {device}", *settings, "write com close"):
            self.cable_command(command)
        self.network = Network()
        self.phones = [f"+42070000000{i}" for i in range(1, phones + 1)]
        for phone in self.phones:
            self.network.add_phone(phone)
        self.network.gateway.hosts.update(
            {"smtp.example.net": "127.0.0.1", "pop3.example.net": "127.0.0.1"}
        )
        self.modem = Modem(ModemConfig())
        self.system = GsmSystem(self.network)
        self.line = self.engine.attach_modem(self.now)
        assert self.engine.modem is not None
        self.driver = self.engine.modem.driver
        #: Seconds each chunk spends on the wire; where chunks are cut (positions).
        self.latency = 0.0
        self.cuts: Callable[[bytes], list[int]] = lambda data: []
        self._to_modem: list[tuple[float, bytes]] = []
        self._to_logger: list[tuple[float, bytes]] = []
        self.phone_events: list[PhoneEvent] = []
        self.smtp_refuse = False
        self.mails: list[bytes] = []
        self.mailbox: list[bytes] = []
        self.pop3_delay = 0.0
        self._peers: dict[int, Smtp | Pop3] = {}
        self._later: list[tuple[float, int, bytes]] = []
        #: What the logger wrote to the modem while the modem was in data mode, one stream
        #: for each time it was.
        self.in_data_mode: list[bytes] = []
        self._data_stream = False
        #: Everything the logger wrote on its modem line (messages go there as plain text
        #: while no modem answers: gsm.md §3).
        self.logger_wrote = b""
        self._system(self.system.add_modem(LOGGER, self.modem, self.now))

    # -- the outside world ---------------------------------------------------------------
    def cable_command(self, command: str) -> None:
        out = self.engine.receive(self.cable, command.encode("latin-1") + b"\r", self.now)
        self._engine(out)

    def network_call(self, items: list[object]) -> None:
        self._system(self.system.network_call(items, self.now))

    def sms(self, sender: str, text: str) -> None:
        self.network_call(self.network.phone_sms(sender, LOGGER, text, self.now))

    def coverage(self, covered: bool) -> None:
        self.network_call(self.network.set_coverage(LOGGER, covered, self.now))

    def received(self, phone: str) -> list[str]:
        return [s.text for s in self.network.delivered(phone)]

    # -- the clock -------------------------------------------------------------------------
    def run(self, seconds: float) -> None:
        end = self.now + seconds
        for _ in range(200_000):
            due = self._next_due()
            if due is None or due > end:
                break
            self._step(max(self.now, due))
        else:
            raise AssertionError("the world never goes quiet")
        self._step(end)

    def _next_due(self) -> float | None:
        times = [self.engine.next_deadline(), self.system.next_deadline(self.now)]
        if self._to_modem:
            times.append(self._to_modem[0][0])
        if self._to_logger:
            times.append(self._to_logger[0][0])
        if self._later:
            times.append(self._later[0][0])
        return min((t for t in times if t is not None), default=None)

    def _step(self, now: float) -> None:
        self.now = now
        while self._to_modem and self._to_modem[0][0] <= now:
            data = self._to_modem.pop(0)[1]
            self.logger_wrote += data
            if self.modem.mode == "data":
                if not self._data_stream:
                    self.in_data_mode.append(b"")
                self.in_data_mode[-1] += data
            self._data_stream = self.modem.mode == "data"
            self._system(self.system.modem_input(LOGGER, data, now))
        while self._to_logger and self._to_logger[0][0] <= now:
            data = self._to_logger.pop(0)[1]
            self._engine(self.engine.receive(self.line, data, now))
        while self._later and self._later[0][0] <= now:
            _, conn, data = self._later.pop(0)
            if conn in self._peers:
                self._ip(gw.Received(conn, data))
        self._system(self.system.advance(now))
        self._engine(self.engine.advance(now))

    # -- wiring ----------------------------------------------------------------------------
    def _wire(self, queue: list[tuple[float, bytes]], data: bytes) -> None:
        at = max(self.now + self.latency, queue[-1][0] if queue else self.now)
        points = sorted({p for p in self.cuts(data) if 0 < p < len(data)})
        start = 0
        for point in [*points, len(data)]:
            queue.append((at, data[start:point]))
            start = point

    def _engine(self, sends: list[LineSend]) -> None:
        for send in sends:
            if send.line == self.line:
                self._wire(self._to_modem, send.data)
            else:
                self.cable_out += send.data

    def _system(self, out: SystemOutput) -> None:
        data = out.line(LOGGER)
        if data:
            self._wire(self._to_logger, data)
        self.phone_events += out.phones
        for effect in out.ip:
            self._serve(effect)

    def _ip(self, event: gw.IpEvent) -> None:
        self._system(self.system.ip_event(event, self.now))

    def _serve(self, effect: gw.IpEffect) -> None:
        """The scripted SMTP (port 25) and POP3 servers behind the IP gateway."""
        if isinstance(effect, gw.Connect):
            peer = Smtp() if effect.port == 25 else Pop3(self.mailbox, self.pop3_delay)
            self._peers[effect.conn] = peer
            self._ip(gw.Connected(effect.conn))
            self._ip(gw.Received(effect.conn, peer.greeting))
        elif isinstance(effect, gw.Send) and effect.conn in self._peers:
            peer = self._peers[effect.conn]
            Smtp.refuse = self.smtp_refuse
            Smtp.mails = self.mails
            for answer in peer.feed(effect.data):
                if answer == b"CLOSE":
                    self._peers.pop(effect.conn, None)
                    self._ip(gw.Closed(effect.conn))
                elif answer.startswith(b"LATER"):
                    self._later.append((self.now + self.pop3_delay, effect.conn, answer[5:]))
                else:
                    self._ip(gw.Received(effect.conn, answer))
        elif isinstance(effect, gw.Close):
            self._peers.pop(effect.conn, None)
