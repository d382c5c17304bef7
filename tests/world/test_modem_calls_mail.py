"""The modem driver: e-mail, POP3 commands, calls, idle modes, presence, readings."""

from __future__ import annotations

from gsm_world import LOGGER, PHONE, PHONE2, Smtp, World

from sondalog.ala1.engine import Engine
from sondalog.ala1.outbox import Destination
from sondalog.gsm.gateway import Accepted, Close, Listen, Received, Send
from sondalog.protocol.device import LineSend

MAIL = ("write com network smtp address smtp.example.net",
        "write com network pop3 address logger@example.net:secret@pop3.example.net",
        "write email send from logger@example.net")  # fmt: skip


def mail_world(*extra: str) -> World:
    w = World("wavecom41", *MAIL, *extra)
    w.network.gateway.hosts.update(
        {"smtp.example.net": "127.0.0.1", "pop3.example.net": "127.0.0.1"}
    )
    Smtp.mails.clear()
    w.run(5)
    return w


def command_mail(command: str, size: int = 0) -> bytes:
    body = f"##*#{command}##*#\r\n" + "x" * size
    return (f"From: user@example.net\r\nSubject: cmd\r\n\r\n{body}\r\n").encode()


def test_sms_with_return_address_is_answered_by_email() -> None:
    w = mail_world()
    w.phone_sms("##*#read com speed##*# startemailuser@example.netendemail")
    w.run(30)
    assert w.sms_to(PHONE) == []
    assert len(Smtp.mails) == 1
    assert b"To: user@example.net" in Smtp.mails[0]
    assert Smtp.mails[0].endswith(b"\r\n9600\r\nOK\r\n")


def test_email_message_then_the_mailbox_command_is_answered() -> None:
    w = mail_world()
    w.mailbox.append(command_mail("read com speed"))
    ident = w.send("data\r\nOK\r\n", Destination("email", "user@example.net"))
    w.run(60)
    assert (ident, True) in w.done
    assert w.mailbox == []  # taken and deleted
    assert len(Smtp.mails) == 2  # the message, then the reply to the e-mailed command
    assert Smtp.mails[1].endswith(b"\r\n9600\r\nOK\r\n")


def test_pop3_over_size_is_deleted_unread() -> None:
    w = mail_world("write com network pop3 size 100")
    w.mailbox.append(command_mail("read com speed", size=500))
    w.send("data", Destination("email", "user@example.net"))
    w.run(60)
    assert w.mailbox == []
    assert len(Smtp.mails) == 1  # no reply: the command was never read


def test_pop3_over_time_is_abandoned_and_kept() -> None:
    w = mail_world("write com network pop3 time 5")
    w.pop3_delay = 10.0
    w.mailbox.append(command_mail("read com speed"))
    w.send("data", Destination("email", "user@example.net"))
    w.run(60)
    assert len(w.mailbox) == 1
    assert len(Smtp.mails) == 1


def test_ring_voice_and_ring_data_run_their_message() -> None:
    w = World("wavecom41", "write address 2 type ringvoice 3", f"write address 2 value {PHONE}",
              "write address 4 type ringdata 5", f"write address 4 value {PHONE2}")  # fmt: skip
    runs: list[int] = []
    w.link.on_ring = lambda m, now: runs.append(m)
    w.run(5)
    w.call("voice")
    w.run(3)
    w.call("data", PHONE2)
    w.run(3)
    assert runs == [3, 5]
    assert b"ATA\r" not in w.modem_saw()
    ended = [p for p in w.phones if p.kind == "ended"]
    assert len(ended) == 2


def test_data_call_session_and_idle_hang_up() -> None:
    w = World("wavecom41")
    w.run(5)
    call_id = w.call("data")
    w.run(1)
    assert w.driver.busy
    w.phone_data(call_id, b"read com speed\r")
    w.run(1)
    data = b"".join(p.data for p in w.phones if p.kind == "data")
    assert data.endswith(b"9600\r\nOK\r\n")
    w.run(100)
    assert not [p for p in w.phones if p.kind == "ended"]
    w.run(30)
    assert [p for p in w.phones if p.kind == "ended"]
    assert not w.driver.busy


def test_wavecom40_radio_off_between_sendings() -> None:
    w = World("wavecom40")
    w.run(5)
    assert not w.network.subscriber(LOGGER).radio
    w.phone_sms("##*#read com speed##*#")
    assert w.sms_to(PHONE) == []  # waits at the SMS centre
    w.send("hello", Destination("sms", PHONE2))
    w.run(20)
    assert w.sms_to(PHONE2) == ["hello"]
    assert w.sms_to(PHONE) == ["9600\r\nOK\r\n"]  # delivered and answered while on
    assert not w.network.subscriber(LOGGER).radio


def test_wavecom42_listens_on_port_10001_as_a_command_session() -> None:
    w = World("wavecom42", "write com network apn address internet")
    w.network.gateway.publish(LOGGER, 10001, 20001)
    w.run(10)
    listens = [e for e in w.ip if isinstance(e, Listen)]
    assert listens and listens[0].port == 20001
    assert w.network.gateway.listening(LOGGER) == [10001]


def test_network_delay_after_registration() -> None:
    w = World("wavecom40", "write com network delay 30")
    w.run(5)
    w.send("x", Destination("sms", PHONE))
    w.run(20)
    assert w.sms_to(PHONE) == []
    w.run(20)
    assert w.sms_to(PHONE) == ["x"]


def test_signal_and_credit_read_at_each_communication() -> None:
    w = World("wavecom41", "write com status sim credit code /*101#/credit is/")
    w.network.set_credit(LOGGER, 250.0)
    w.run(5)
    hw = w.engine.state.measurer.hardware
    assert hw.gsm("signal", w.now) is None  # no communication yet
    w.send("x", Destination("sms", PHONE))
    w.run(5)
    assert hw.gsm("signal", w.now) == 18.0
    assert hw.gsm("credit", w.now) == 250.0


def _paced(engine: Engine, effects: list[LineSend], start: float) -> bytes:
    """What ``effects`` sent plus what the paced modem line releases in the next 50 ms."""
    out = b"".join(s.data for s in effects)
    t = start
    while (due := engine.next_deadline()) is not None and due <= start + 0.05:
        t = max(t, due)
        out += b"".join(s.data for s in engine.advance(t))
    return out


def test_no_modem_the_line_works_as_local_and_service_resumes() -> None:
    w = World("wavecom41")
    # a second logger whose com line has no modem behind it
    engine = w.engine.__class__(w.engine.identity, w.store, w.now)
    engine.receive(engine.open_line(), b"write com device wavecom41\r", w.now)
    line = engine.attach_modem(w.now)
    # ESC first: it ends a "> " prompt a modem may still wait at (gsm.md §7)
    assert _paced(engine, engine.advance(w.now), w.now) == b"\x1bAT\r"  # paced at com speed
    assert not _paced(engine, engine.advance(w.now + 1.0), w.now + 1.0)
    answer = engine.receive(line, b"read com speed\r", w.now + 2)
    assert _paced(engine, answer, w.now + 2) == b"9600\r\nOK\r\n"
    due = engine.next_deadline()
    assert due is not None and due >= w.now + 30
    assert _paced(engine, engine.advance(due), due) == b"\x1bAT\r"
    back = engine.receive(line, b"\r\nOK\r\n", due + 0.1)
    assert not _paced(engine, back, due + 0.1)  # a second answer would show it was late
    assert _paced(engine, engine.advance(due + 1.2), due + 1.2) == b"ATE0\r"


def test_port_10001_connection_is_a_command_session_with_idle_hang_up() -> None:
    w = World("wavecom42", "write com network apn address internet")
    w.network.gateway.publish(LOGGER, 10001, 20001)
    w.run(10)
    listener = next(e for e in w.ip if isinstance(e, Listen)).listener
    w.event(Accepted(listener, 900))
    w.run(1)
    assert w.driver.busy
    w.event(Received(900, b"read com speed\r"))
    w.run(1)
    sent = b"".join(e.data for e in w.ip if isinstance(e, Send) and e.conn == 900)
    assert sent == b"9600\r\nOK\r\n"
    w.run(110)
    assert not any(isinstance(e, Close) and e.conn == 900 for e in w.ip)
    w.run(20)
    assert any(isinstance(e, Close) and e.conn == 900 for e in w.ip)
    assert not w.driver.busy
    assert w.network.gateway.listening(LOGGER) == [10001]  # still listening for the next


def test_smtp_refusing_fails_the_sending() -> None:
    w = mail_world()
    Smtp.refuse = True
    try:
        ident = w.send("data", Destination("email", "user@example.net"))
        w.run(60)
    finally:
        Smtp.refuse = False
    assert w.done == [(ident, False)]
    assert Smtp.mails == []


def test_credit_and_signal_channels_show_the_readings() -> None:
    w = World(
        "wavecom41",
        "write com status sim credit code /*101#/",
        "write channel max number 2",
        "write channel 1 type 11",
        "write channel 2 type 12",
    )
    w.network.set_credit(LOGGER, 123.5)
    w.run(5)
    before = w.engine.receive(w.cable, b"read channel 2 value\r", w.now)
    assert b"".join(s.data for s in before).endswith(b"OK\r\n")
    w.send("x", Destination("sms", PHONE))
    w.run(5)
    credit = w.ask("read channel 1 value")
    signal = w.ask("read channel 2 value")
    assert credit.startswith(b"123.5"), credit
    assert signal.startswith(b"18"), signal
    assert before != signal


def test_wavecom42_attaches_again_after_coverage_returns() -> None:
    w = World("wavecom42", "write com network apn address internet")
    w.network.gateway.publish(LOGGER, 10001, 20001)
    w.run(10)
    assert w.network.gateway.listening(LOGGER) == [10001]
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, False, w.now), w.now))
    w.run(5)
    assert w.network.gateway.listening(LOGGER) == []
    assert not w.driver.gprs
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, True, w.now), w.now))
    w.run(70)
    assert w.network.gateway.listening(LOGGER) == [10001]


def test_com_device_local_keeps_the_line_a_cable_line() -> None:
    w = World("local")
    w.run(5)
    assert w.modem_saw() == b""  # no AT: nothing is driven
    out = w.engine.receive(w.site.modem_line, b"read com speed\r", w.now)
    assert _paced(w.engine, out, w.now) == b"9600\r\nOK\r\n"


def test_mail_without_a_bounded_command_is_deleted_and_ignored() -> None:
    w = mail_world()
    w.mailbox.append(b"From: user@example.net\r\nSubject: hi\r\n\r\nno command here\r\n")
    w.send("data", Destination("email", "user@example.net"))
    w.run(60)
    assert w.mailbox == []
    assert len(Smtp.mails) == 1
