"""SMS on the modem, text and PDU mode, byte-exact (gsm.md §2, 27.005)."""

from __future__ import annotations

from gsm_helpers import MODEM, PHONE, PHONE2, Bench

from sondalog.gsm import events as ev
from sondalog.gsm import pdu


def test_text_mode_send_as_the_logger_does() -> None:
    b = Bench()
    assert b.at("AT+CMGF=1") == b"\r\nOK\r\n"
    assert b.at(f'AT+CMGS="{PHONE}"') == b"\r\n> "
    # echo off: each CR of the text only brings the prompt back
    assert b.send(b"read com speed\r\n9600\r\nOK\r\n") == b"\r\n> " * 3
    assert b.send(b"\x1a") == b"\r\n+CMGS: 1\r\n\r\nOK\r\n"
    (sms,) = b.network.delivered(PHONE)
    assert (sms.sender, sms.text) == (MODEM, "read com speed\r\n9600\r\nOK\r\n")
    assert b.last.phones[0].kind == "sms"


def test_text_mode_echo_prompt_and_escape() -> None:
    b = Bench(echo=True)
    b.at("AT+CMGF=1")
    assert b.at(f'AT+CMGS="{PHONE}"') == f'AT+CMGS="{PHONE}"\r\r\n> '.encode()
    assert b.send(b"a\rb") == b"a\r\n> b"
    assert b.send(b"\x1b") == b"\r\nOK\r\n"
    assert b.network.delivered(PHONE) == []
    b.at(f'AT+CMGS="{PHONE}"')
    assert b.send(b"x\x1a") == b"x\r\n+CMGS: 1\r\n\r\nOK\r\n"


def test_characters_outside_gsm7_become_question_marks() -> None:
    b = Bench()
    b.at("AT+CMGF=1")
    b.at(f'AT+CMGS="{PHONE}"')
    b.send("teplota 5 °C ± 1 ¥".encode("latin-1") + b"\x1a")  # text mode reads ISO 8859-1
    assert b.network.delivered(PHONE)[0].text == "teplota 5 ?C ? 1 ¥"


def test_text_over_160_characters_is_refused() -> None:
    b = Bench()
    b.at("AT+CMGF=1;+CMEE=1")
    b.at(f'AT+CMGS="{PHONE}"')
    assert b.send(b"a" * 161 + b"\x1a") == b"\r\n+CMS ERROR: 305\r\n"
    b.at(f'AT+CMGS="{PHONE}"')
    assert b.send(b"[" * 81 + b"\x1a") == b"\r\n+CMS ERROR: 305\r\n"  # 2 septets each
    b.at(f'AT+CMGS="{PHONE}"')
    assert b.send(b"a" * 160 + b"\x1a") == b"\r\n+CMGS: 1\r\n\r\nOK\r\n"


def test_no_network_no_sms() -> None:
    b = Bench()
    b.at("AT+CMGF=1;+CMEE=1")
    b.net(lambda n, t: n.set_coverage(MODEM, False, t))
    b.at(f'AT+CMGS="{PHONE}"')
    assert b.send(b"x\x1a") == b"\r\n+CMS ERROR: 331\r\n"


def test_pdu_mode_send_as_gammu_does() -> None:
    b = Bench()
    b.at("AT+CMGF=0;+CMEE=1")
    assert b.at("AT+CMGS=16") == b"\r\n> "
    out = b.send(b"079124603050020011000C912470000000100000FF02E834\x1a")
    assert out == b"\r\n+CMGS: 1\r\n\r\nOK\r\n"
    assert b.network.delivered(PHONE)[0].text == "hi"
    b.at("AT+CMGS=15")  # wrong length
    assert b.send(b"079124603050020011000C912470000000100000FF02E834\x1a") == (
        b"\r\n+CMS ERROR: 304\r\n"
    )
    b.at("AT+CMGS=16")
    assert b.send(b"07912460305002ZZ\x1a") == b"\r\n+CMS ERROR: 304\r\n"


def test_received_sms_text_mode_read_list_delete() -> None:
    b = Bench()
    b.at("AT+CMGF=1")
    out = b.net(lambda n, t: n.phone_sms(PHONE, MODEM, "##*#read com speed##*#", t))
    assert out.line(MODEM) == b'\r\n+CMTI: "SM",1\r\n'
    assert b.at("AT+CPMS?") == b'\r\n+CPMS: "SM",1,30,"SM",1,30,"SM",1,30\r\n\r\nOK\r\n'
    assert b.at("AT+CMGR=1") == (
        b'\r\n+CMGR: "REC UNREAD","+420700000001",,"25/11/30,01:00:00+00"\r\n'
        b"##*#read com speed##*#\r\n\r\nOK\r\n"
    )
    b.net(lambda n, t: n.phone_sms(PHONE2, MODEM, "second", t))
    assert b.at('AT+CMGL="ALL"') == (
        b'\r\n+CMGL: 1,"REC READ","+420700000001",,"25/11/30,01:00:00+00"\r\n'
        b"##*#read com speed##*#\r\n"
        b'+CMGL: 2,"REC UNREAD","+420700000002",,"25/11/30,01:00:00+00"\r\n'
        b"second\r\n\r\nOK\r\n"
    )
    assert b.at("AT+CMGD=1") == b"\r\nOK\r\n"
    assert b.at("AT+CMEE=1;+CMGR=1") == b"\r\n+CMS ERROR: 321\r\n"
    assert b.at("AT+CMGR=31") == b"\r\n+CMS ERROR: 321\r\n"
    assert b.at('AT+CMGL="REC UNREAD"') == b"\r\nOK\r\n"


def test_received_sms_pdu_mode() -> None:
    b = Bench(tz_quarters=4)
    b.net(lambda n, t: n.phone_sms(PHONE, MODEM, "hi", t))
    out = b.at("AT+CMGF=0;+CMGR=1")
    header, body = out.split(b"\r\n")[1:3]
    raw = bytes.fromhex(body.decode())
    assert header == f"+CMGR: 0,,{pdu.tpdu_length(raw)}".encode()
    sms = pdu.decode_deliver(raw)
    assert (sms.originator, sms.text, sms.smsc, sms.tz_quarters) == (
        PHONE,
        "hi",
        "+420603052000",
        4,
    )
    assert sms.timestamp == int(b.now)
    assert b.at("AT+CMGL=4").startswith(b"\r\n+CMGL: 1,1,,")


def test_sms_wait_while_radio_off_and_come_when_on() -> None:
    b = Bench()
    b.at("AT+CFUN=0")
    assert b.net(lambda n, t: n.phone_sms(PHONE, MODEM, "later", t)).line(MODEM) == b""
    assert [s.text for s in b.network.queued(MODEM)] == ["later"]
    assert b.at("AT+CFUN=1") == b'\r\nOK\r\n\r\n+CMTI: "SM",1\r\n'
    assert b.network.queued(MODEM) == []


def test_full_store_keeps_sms_at_the_centre() -> None:
    b = Bench(store_size=2)
    for text in ("one", "two", "three"):
        b.net(lambda n, t, text=text: n.phone_sms(PHONE, MODEM, text, t))  # type: ignore[misc]
    assert [s.text for s in b.network.queued(MODEM)] == ["three"]
    assert b.at("AT+CMGD=1") == b'\r\nOK\r\n\r\n+CMTI: "SM",1\r\n'
    assert b.network.queued(MODEM) == []
    assert b.modem.store.get(1) is not None and b.modem.store.get(1).text == "three"  # type: ignore[union-attr]


def test_cnmi_can_silence_cmti() -> None:
    b = Bench()
    b.at("AT+CNMI=0,0")
    assert b.net(lambda n, t: n.phone_sms(PHONE, MODEM, "quiet", t)).line(MODEM) == b""
    assert b.at("AT+CNMI?") == b"\r\n+CNMI: 0,0,0,0,0\r\n\r\nOK\r\n"
    assert isinstance(ev.SmsAccepted(1), ev.SmsAccepted)
