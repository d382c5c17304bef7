"""gsm.md §7, one test per symptom that wedged or muted the logger (issue 20), on the pure
cores: the logger's engine and modem driver, the modem core, the network core."""

from __future__ import annotations

from gsm_world import LOGGER, PHONE, PHONE2, World
from live_world import AT_LINE, LiveWorld

from sondalog.ala1.modem.atio import ModemReader
from sondalog.ala1.modem.session import NO_CARRIER, SHUTDOWN, EndMarker

COMMAND = "##*#read i version##*#"
ANSWER = "2.10\r\nOK\r\n"


def test_an_sms_arriving_while_the_modem_is_set_up_is_answered() -> None:
    """Symptom 1: the ``+CMTI`` came before the driver's first probe; the line took the
    modem's bytes as terminal input and echoed them back; SIM slot 1 was never read."""
    w = World("wavecom42")
    w.phone_sms(COMMAND)  # at once: the logger has not even sent its first AT
    w.run(60)
    assert w.sms_to(PHONE) == [ANSWER]
    assert b"+CMTI" not in w.modem_saw()  # nothing the modem said went back to it
    assert len(w.modem.store) == 0


def test_an_sms_stored_without_a_notice_is_found_by_the_listing() -> None:
    """``+CMTI`` is a hint: an SMS stored before ``AT+CNMI`` was set has none."""
    w = World()
    w.modem.settings.cnmi = (0, 0, 0, 0, 0)
    w.phone_sms(COMMAND)
    w.run(60)
    assert b'AT+CMGL="ALL"\r' in w.modem_saw()
    assert w.sms_to(PHONE) == [ANSWER]
    assert len(w.modem.store) == 0


def test_an_sms_arriving_during_a_data_call_is_answered_after_it() -> None:
    """Symptom 3a: the modem holds its ``+CMTI`` until the call ends and sends it in the
    same read as ``NO CARRIER``; the session threw away what followed its end marker."""
    w = World()
    w.run(5)
    call = w.call("data", PHONE2)
    w.run(3)
    w.phone_data(call, b"read i version\r")
    w.run(2)
    w.phone_sms(COMMAND)
    w.run(2)
    assert w.sms_to(PHONE) == []  # held while the call lasts
    w.collect(w.site.network_call(lambda n: n.phone_hang_up(call, w.now), w.now))
    w.run(30)
    assert w.sms_to(PHONE) == [ANSWER]
    assert len(w.modem.store) == 0


def test_a_reply_refused_for_lost_coverage_is_sent_when_the_network_is_back() -> None:
    """Symptom 3b: ``AT+CMGS`` failed with ``+CMS ERROR: 331`` (coverage lost after the
    registration check) and the command, already deleted from the SIM, was lost."""
    w = World("wavecom41", "write com network delay 10")
    w.run(5)
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, False, w.now), w.now))
    w.phone_sms(COMMAND)  # waits at the centre
    w.run(5)
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, True, w.now), w.now))
    w.run(2)  # delivered, read, deleted, executed; the reply waits for the network delay
    assert len(w.modem.store) == 0
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, False, w.now), w.now))
    w.run(60)
    assert b"+CMS ERROR: 331" in b"".join(b for d, b in w.trace if d == "tx")
    assert w.sms_to(PHONE) == []
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, True, w.now), w.now))
    w.run(120)
    assert w.sms_to(PHONE) == [ANSWER]  # once


def test_a_late_answer_never_makes_the_logger_send_at_commands_in_data_mode() -> None:
    """Symptom 2: a late ``OK`` (the answer to an earlier command) came while the logger
    waited for ``CONNECT`` after ``ATA``; it went on with ``AT+CSQ`` in data mode (the caller
    got it), the caller's commands went unanswered, the driver never recovered."""
    w = LiveWorld()
    w.latency = 0.2
    w.run(20)
    call_id, items = w.network.phone_call(w.phones[1], LOGGER, "data", w.now)
    w.network_call(items)
    for _ in range(100):
        w.run(0.05)
        wait = w.driver._wait
        if wait is not None and getattr(wait, "line", "") == "ATA":
            break
    else:
        raise AssertionError("the logger never answered the call")
    w._to_logger.insert(0, (w.now + 0.01, b"\r\nOK\r\n"))  # late, before CONNECT
    w.run(5)
    w.network_call(w.network.phone_data(call_id, b"read i version\r"))
    w.run(5)
    said = b"".join(e.data for e in w.phone_events if e.kind == "data" and e.call_id == call_id)
    assert b"2.10\r\nOK\r\n" in said
    assert b"AT+" not in said
    w.network_call(w.network.phone_hang_up(call_id, w.now))
    w.run(30)
    assert not any(AT_LINE.search(chunk) for chunk in w.in_data_mode)
    w.sms(w.phones[0], COMMAND)  # the driver still talks to its modem
    w.run(60)
    assert w.received(w.phones[0]) == [ANSWER]


def test_coverage_lost_in_a_mail_session_leaves_the_modem_usable() -> None:
    """The modem drops a GPRS session with ``NO CARRIER`` (not ``SHUTDOWN``) when coverage
    goes: the logger must not send ``+++`` into command mode and lose what followed."""
    w = LiveWorld(
        "wavecom41",
        "write com network smtp address smtp.example.net",
        "write com network pop3 address logger@example.net:secret@pop3.example.net",
    )
    w.run(10)
    w.pop3_delay = 30.0
    w.mailbox.append(b"From: a@example.net\r\n\r\n##*#read i version##*#\r\n")
    w.sms(w.phones[0], COMMAND + " startemailuser@example.netendemail")
    w.run(20)  # the reply went by e-mail; the mailbox check waits for RETR
    w.coverage(False)
    w.sms(w.phones[0], COMMAND)  # waits at the centre
    w.run(20)
    w.coverage(True)
    w.run(300)
    assert w.received(w.phones[0]) == [ANSWER]
    assert len(w.modem.store) == 0
    assert not any(AT_LINE.search(chunk) for chunk in w.in_data_mode)


def test_the_end_marker_keeps_what_follows_it() -> None:
    end = EndMarker(NO_CARRIER)
    data, ended = end.cut(b"OK\r\n\r\nNO CAR")
    assert not ended
    data, ended = end.cut(b'RIER\r\n\r\n+CMTI: "SM",1\r\n')
    assert ended and data == b""
    assert end.rest == b'\r\n+CMTI: "SM",1\r\n'
    either = EndMarker(SHUTDOWN, NO_CARRIER)
    assert either.cut(b"+OK\r\n\r\nNO CARRIER\r\n\r\n+CREG: 0\r\n") == (b"+OK\r\n", True)
    assert either.found == NO_CARRIER and either.rest == b"\r\n+CREG: 0\r\n"


def test_the_reader_is_bounded() -> None:
    reader = ModemReader()
    assert reader.feed(b"x" * 100_000) == []
    assert len(reader.buffer) <= 4096
    reader.raw = True
    reader.feed(b"y" * 100_000)
    assert len(reader.data) <= 16384


def test_input_held_while_local_is_dropped_whole_when_the_modem_takes_the_line() -> None:
    """A ``pause`` typed on the com line while it worked as local, and flooded past its
    backlog, leaves nothing behind once the driver has the line again: the next ``pause``
    on a local line keeps its input (no stale overrun)."""
    from sondalog.ala1 import Engine, Identity, Version
    from sondalog.backends.store.ala1_nv import SqliteNvStore

    now = 0.0
    engine = Engine(Identity(Version.V2_10), SqliteNvStore(":memory:"), now)
    engine.receive(engine.open_line(), b"write com device wavecom41\r", now)
    line = engine.attach_modem(now)
    out = b""

    def run(until: float) -> None:
        nonlocal now, out
        while (due := engine.next_deadline()) is not None and due <= until:
            now = max(now, due)
            out += b"".join(s.data for s in engine.advance(now) if s.line == line)
        now = until

    def send(data: bytes) -> None:
        nonlocal out
        out += b"".join(s.data for s in engine.receive(line, data, now) if s.line == line)

    run(2.0)  # the first probe went unanswered: the line works as local
    send(b"pause 30 read i version\r" + b"x" * 8000)  # more than the FIFO holds
    send(b"\r\nOK\r\n")  # a modem speaks: the driver takes the line
    assert engine.modem is not None
    while engine.modem.driver.local:  # it probes soon, however busy the line
        run(now + 0.5)
        assert now < 60.0
    while not engine.modem.driver.local:  # its probes go unanswered: local again
        run(now + 0.5)
        assert now < 300.0
    out = b""
    send(b"pause 1 read i version\r")
    send(b"read com speed\r")
    run(now + 3.0)
    assert out.endswith(b"9600\r\nOK\r\n"), out


def test_an_sms_whose_text_is_empty_lines_is_read_and_the_driver_goes_idle() -> None:
    """Found by the liveness search: an SMS of one LF listed as ``+CMGL: ...`` then an empty
    text line; the reader dropped empty lines, took the listing's ``OK`` for the text, and
    the listing timed out and started again for good."""
    for text in ("\n", "\r\n", "\n\n"):
        w = World("wavecom41")
        w.phone_sms(text)
        w.run(120)
        assert len(w.modem.store) == 0, repr(text)  # read and deleted
        assert w.driver._job is None, repr(text)  # and the driver idle


def test_the_reader_keeps_an_sms_text_even_when_empty() -> None:
    reader = ModemReader()
    head = '+CMGL: 1,"REC UNREAD","+420600000000",,"26/01/01,00:00:00+04"'
    lines = reader.feed(f"\r\n{head}\r\n\n\r\n\r\nOK\r\n".encode())
    assert lines == [head, "", "OK"]
    assert reader.feed(b'\r\n+CMGR: "REC READ","+420600000000",,"x"\r\n+CMGL: 2\r\n\r\nOK\r\n') == [
        '+CMGR: "REC READ","+420600000000",,"x"',
        "+CMGL: 2",  # the text, not a header: the next empty line is dropped
        "OK",
    ]
