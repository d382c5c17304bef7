"""The search for the next wedge (gsm.md §7): random schedules of everything that happens
to a remote logger, then quiet, then the liveness properties.

A hypothesis :class:`RuleBasedStateMachine` over :class:`live_world.LiveWorld` (the logger's
engine and modem driver, the modem core, the network core, scripted mail servers, a slow
modem line that cuts its bytes) on a stepped clock. Rules: SMS arriving (bounded commands
answered by SMS, long replies, replies by e-mail, SMS without a command, non-GSM-7 text),
voice and data calls (ring triggers and plain sessions, the caller hanging up at any byte),
coverage lost and regained, the network restarting, the radio switched by the idle mode
(``wavecom40/41/42``), messages falling due (run at once, and a periodic one),
SMTP refusing and POP3 slow, a modem line that is slow or stalls, and cable sessions. After
the schedule the world goes quiet for :data:`QUIET` seconds and :meth:`GsmLiveness.teardown`
asserts: the driver idle, the SIM store empty, every bounded SMS command answered exactly
once (at least once after a stall longer than the time limits, where an answer the modem
took may come too late to count), no AT command sent in data mode, no message data lost
(sent by SMS, or on the line as plain text while no modem answered, as gsm.md §3 has it).

``tests/world/test_modem_liveness_search.py`` runs a few hundred schedules in ``make test``;
``benchmarks/soak_gsm.py`` runs thousands.
"""

from __future__ import annotations

import random

from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, rule
from live_world import AT_LINE, LOGGER, LiveWorld

from sondalog.ala1.modem.text import gsm7_text, split_sms

#: Seconds of quiet after a schedule: a few ``com network delay``s, the longest time limit
#: (a mail session), the reply backoff's longest wait.
QUIET = 900.0
SHORT = "##*#read i version##*#"
SHORT_ANSWER = "2.10\r\nOK\r\n"
LONG = "##*#" + " ".join(["read address 9 value"] * 4) + "##*#"
LONG_ADDRESS = "stanice.dvanact.na.kopci.u.lesa@example.net"
LONG_ANSWER = (LONG_ADDRESS + "\r\n") * 4 + "OK\r\n"
MAIL_TO = "ops@example.net"
SETTINGS = (
    "write com network smtp address smtp.example.net",
    "write com network pop3 address logger@example.net:secret@pop3.example.net",
    "write com network delay 2",
    "write address 9 type email",
    f"write address 9 value {LONG_ADDRESS}",
    "write command 1 name /data/",
    "write command 1 value/read record 10 from lastread shift/",
)


class GsmLiveness(RuleBasedStateMachine):
    """Phones: 0 short commands, 1 long ones, 2 e-mail replies, 3 noise and calls,
    4 message 1 (``address 1``), 5 ``ringvoice 1`` (runs message 1), 6 the periodic
    message 2."""

    def __init__(self) -> None:
        super().__init__()
        self.w: LiveWorld | None = None
        self.short = self.long = self.mail = 0
        self.tags: list[str] = []
        self.calls: list[int] = []
        self.stalled = False
        self.device = "wavecom41"

    @initialize(device=st.sampled_from(["wavecom41", "wavecom42"]))
    def start(self, device: str) -> None:
        self.device = device
        w = LiveWorld(device, *SETTINGS, phones=7)
        for command in (
            f"write address 1 type sms write address 1 value {w.phones[4]}",
            "write message 1 address 1 write message 1 command 1",
            f"write address 2 type ringvoice 1 write address 2 value {w.phones[5]}",
            # message 2 falls due every 10 minutes by itself (§6.14.4-5)
            "write command 2 name /version/ write command 2 value/read i version/",
            f"write address 3 type sms write address 3 value {w.phones[6]}",
            "write message 2 address 3 write message 2 command 2",
            "write message 2 start 20000101000000",
            "write message 2 period 001000",
            "write com close",
        ):
            w.cable_command(command)
        self.w = w

    @property
    def world(self) -> LiveWorld:
        assert self.w is not None
        return self.w

    # -- time and the line ---------------------------------------------------------------
    @rule(seconds=st.sampled_from([0.0, 0.003, 0.05, 0.4, 1.0, 3.0, 12.0, 45.0, 130.0]))
    def wait(self, seconds: float) -> None:
        self.world.run(seconds)

    @rule(latency=st.sampled_from([0.0, 0.0, 0.002, 0.05, 0.3]))
    def line_latency(self, latency: float) -> None:
        self.world.latency = latency

    @rule(seed=st.integers(0, 2**16), density=st.sampled_from([0, 2, 8, 40]))
    def line_cuts(self, seed: int, density: int) -> None:
        rng = random.Random(seed)
        self.world.cuts = lambda data: [
            rng.randrange(len(data) + 1) for _ in range(rng.randrange(density + 1))
        ]

    @rule(seconds=st.sampled_from([11.0, 25.0, 70.0]))
    def modem_stalls(self, seconds: float) -> None:
        """The modem answers nothing for a while (busy, a firmware hiccup)."""
        w = self.world
        w.latency = seconds
        w.run(seconds)
        w.latency = 0.0
        self.stalled = True

    # -- the network ---------------------------------------------------------------------
    @rule()
    def sms_command(self) -> None:
        self.world.sms(self.world.phones[0], f"please {SHORT}")
        self.short += 1

    @rule()
    def sms_long_reply(self) -> None:
        self.world.sms(self.world.phones[1], LONG)
        self.long += 1

    @rule()
    def sms_reply_by_mail(self) -> None:
        self.world.sms(self.world.phones[2], f"{SHORT} startemail{MAIL_TO}endemail")
        self.mail += 1

    @rule(text=st.text(max_size=200).filter(lambda t: "##*#" not in t))
    def sms_without_command(self, text: str) -> None:
        self.world.sms(self.world.phones[3], text or "hello")

    @rule(kind=st.sampled_from(["voice", "data"]), ring=st.booleans())
    def call(self, kind: str, ring: bool) -> None:
        w = self.world
        caller = w.phones[5] if ring and kind == "voice" else w.phones[3]
        call_id, items = w.network.phone_call(caller, LOGGER, kind, w.now)
        w.network_call(items)
        self.calls.append(call_id)

    @rule(data=st.sampled_from([b"read i version\r", b"read i vers", b"\x1b", b"ion\r\n"]))
    def caller_types(self, data: bytes) -> None:
        w = self.world
        for call_id in self.calls:
            w.network_call(w.network.phone_data(call_id, data))

    @rule()
    def caller_hangs_up(self) -> None:
        w = self.world
        if self.calls:
            w.network_call(w.network.phone_hang_up(self.calls.pop(0), w.now))

    @rule(covered=st.booleans())
    def coverage(self, covered: bool) -> None:
        self.world.coverage(covered)

    @rule()
    def network_restarts(self) -> None:
        """Every cell goes down and comes back (the SMS centre keeps what it queued)."""
        w = self.world
        w.network_call(w.network.set_coverage(None, False, w.now))
        w.run(3.0)
        w.network_call(w.network.set_coverage(None, True, w.now))

    @rule(device=st.sampled_from(["wavecom40", "wavecom41", "wavecom42"]))
    def idle_mode(self, device: str) -> None:
        """The idle mode changed over the cable: ``wavecom40`` switches the radio off between
        communications (SMS wait at the centre), the others on (§6.11.5.2)."""
        self.world.cable_command(f"write com device {device}")
        self.world.cable_command("write com close")

    @rule(refuse=st.booleans(), pop3_delay=st.sampled_from([0.0, 0.0, 20.0, 200.0]))
    def mail_servers(self, refuse: bool, pop3_delay: float) -> None:
        self.world.smtp_refuse = refuse
        self.world.pop3_delay = pop3_delay

    @rule()
    def mail_command_waits(self) -> None:
        """An e-mailed command in the logger's mailbox (answered by e-mail, not counted)."""
        self.world.mailbox.append(b"From: x@example.net\r\n\r\n##*#read com speed##*#\r\n")

    # -- the logger itself ---------------------------------------------------------------
    @rule()
    def message_falls_due(self) -> None:
        tag = f"tag{len(self.tags)}"
        self.tags.append(tag)
        self.world.cable_command(f"write text /{tag}/")
        self.world.cable_command("write message 1 run 1")
        self.world.cable_command("write com close")

    @rule()
    def cable_session(self) -> None:
        self.world.cable_command("read i version")
        self.world.cable_command("write com close")

    # -- the properties ------------------------------------------------------------------
    def teardown(self) -> None:
        if self.w is None:
            return
        w = self.w
        w.latency = 0.0
        w.cuts = lambda data: []
        w.smtp_refuse = False
        w.pop3_delay = 0.0
        w.coverage(True)
        w.network_call(w.network.set_coverage(None, True, w.now))
        w.cable_command(f"write com device {self.device}")  # radio on again (wavecom40)
        w.cable_command("write com close")
        for call_id in self.calls:
            w.network_call(w.network.phone_hang_up(call_id, w.now))
        w.run(QUIET)
        d = w.driver
        state = (d._job is not None, list(d._urcs), d.listing_due, list(d.replies), d.reader.raw)
        assert state == (False, [], False, [], False), f"driver not idle: {state}"
        assert d.present is True and d.applied == self.device.upper(), (d.present, d.applied)
        assert len(w.modem.store) == 0, "SMS left in the SIM store"
        assert not any(AT_LINE.search(c) for c in w.in_data_mode), "AT sent in data mode"
        self._answered(w.received(w.phones[0]), [SHORT_ANSWER] * self.short)
        long_parts = split_sms(gsm7_text(LONG_ANSWER))
        self._answered(w.received(w.phones[1]), long_parts * self.long)
        mails = [m for m in w.mails if f"To: {MAIL_TO}".encode() in m and b"2.10\r\nOK" in m]
        assert (len(mails) >= self.mail) if self.stalled else (len(mails) == self.mail), (
            f"{len(mails)} mails for {self.mail} commands"
        )
        # no message data lost: more sendings (10 rows each: `read record 10 from lastread
        # shift`) carry every row not yet delivered
        for _ in range(len(self.tags) // 10 + 2):
            w.cable_command("write message 1 run 1")
            w.cable_command("write com close")
            w.run(QUIET / 3)
        sent = "".join(w.received(w.phones[4])) + w.logger_wrote.decode("latin-1")
        lost = [t for t in self.tags if f"/{t}/" not in sent]  # by SMS, or as local text
        assert not lost, f"message data lost: {lost}"
        assert w.engine.outbox.peek() is None, "a sending stuck in the outbox"

    def _answered(self, got: list[str], expected: list[str]) -> None:
        if self.stalled:
            assert len(got) >= len(expected), (got, expected)
            assert set(got) <= set(expected) or not expected, (got, expected)
        else:  # each once; replies to one phone may interleave (a retried part comes later)
            assert sorted(got) == sorted(expected), (got, expected)
