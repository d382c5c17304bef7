"""The GSM network core: SMS centre queues, coverage outages, calls, USSD, gateway
(gsm.md §1, §3, §6)."""

from __future__ import annotations

from gsm_helpers import MODEM, PHONE, PHONE2, T0, Bench

from sondalog.gsm import events as ev
from sondalog.gsm.gateway import ModemEvent
from sondalog.gsm.modem import Modem
from sondalog.gsm.network import Network
from sondalog.gsm.sms import joined, normalize


def test_numbers_normalize() -> None:
    assert normalize("00420 700 000 001") == "+420700000001"
    assert normalize("+420-700-000-001") == "+420700000001"


def test_phone_to_phone_sms_and_unknown_numbers() -> None:
    n = Network()
    n.add_phone(PHONE)
    n.add_phone(PHONE2)
    out = n.phone_sms(PHONE, "00420700000002", "ahoj", T0)
    assert [(o.kind, o.sms.text) for o in out] == [("sms", "ahoj")]  # type: ignore[attr-defined, union-attr]
    assert [s.sender for s in n.delivered(PHONE2)] == [PHONE]
    assert n.phone_sms(PHONE, "+999", "lost", T0) == []
    assert [s.text for s in n.undeliverable] == ["lost"]


def test_scheduled_outage_queues_and_delivers_in_order() -> None:
    b = Bench()
    b.network.schedule_outage(T0 + 10, T0 + 70, MODEM)
    assert b.system.next_deadline(b.now) == T0 + 10
    assert b.later(10) == b""  # registration lost: no URC with +CREG=0
    assert not b.modem.registered
    for text in ("first", "second"):
        b.net(lambda n, t, text=text: n.phone_sms(PHONE, MODEM, text, t))  # type: ignore[misc]
    assert [s.text for s in b.network.queued(MODEM)] == ["first", "second"]
    assert b.system.next_deadline(b.now) == T0 + 70
    assert b.later(60) == b'\r\n+CMTI: "SM",1\r\n\r\n+CMTI: "SM",2\r\n'
    assert b.modem.registered and b.network.queued(MODEM) == []
    assert [s.text for s in b.network.delivered(MODEM)] == ["first", "second"]


def test_outage_for_everyone_on_demand() -> None:
    b = Bench()
    b.net(lambda n, t: n.set_coverage(None, False, t))
    assert not b.network.subscriber(PHONE).registered
    b.at("AT+CMGF=1")
    b.net(lambda n, t: n.set_coverage(MODEM, True, t))
    b.at(f'AT+CMGS="{PHONE}"')
    b.send(b"queued for the phone\x1a")
    assert b.network.delivered(PHONE) == []
    out = b.net(lambda n, t: n.set_coverage(PHONE, True, t))
    assert [p.sms.text for p in out.phones] == ["queued for the phone"]  # type: ignore[union-attr]


def test_signal_and_credit_models() -> None:
    n = Network(sms_price=1.5)
    out = n.add_modem(MODEM, T0, credit=250.0, rssi=21)
    assert ModemEvent(MODEM, ev.Signal(21)) in out
    n.add_phone(PHONE)
    assert n.set_signal(MODEM, 40, T0) == [ModemEvent(MODEM, ev.Signal(31))]
    n.from_modem(MODEM, ev.SendSms(PHONE, "x", 1), T0)
    assert n.subscriber(MODEM).credit == 248.5
    n.subscriber(MODEM).ussd["*101#"] = "Zbyva {credit:.2f} Kc do 31.12.2026"
    assert n.from_modem(MODEM, ev.Ussd("*101#"), T0) == [
        ModemEvent(MODEM, ev.UssdAnswer("Zbyva 248.50 Kc do 31.12.2026"))
    ]


def test_data_call_between_two_modems_bridges_bytes() -> None:
    b = Bench()
    other = Modem()
    b.system.add_modem("+420600000002", other, b.now)
    b.system.modem_input("+420600000002", b"ATE0\r", b.now)
    assert b.at("ATD+420600000002") == b""
    assert b.last.line("+420600000002") == b"\r\nRING\r\n"
    out = b.system.modem_input("+420600000002", b"ATA\r", b.now)
    assert out.line("+420600000002") == b"\r\nCONNECT 9600\r\n"
    assert out.line(MODEM) == b"\r\nCONNECT 9600\r\n"
    assert b.send(b"hello") == b""
    assert b.last.line("+420600000002") == b"hello"
    b.later(1.0)
    b.send(b"+++")
    b.later(1.0)
    assert b.at("ATH") == b"\r\nOK\r\n"
    assert b.last.line("+420600000002") == b"\r\nNO CARRIER\r\n"


def test_listening_needs_gprs_and_a_published_port() -> None:
    n = Network()
    n.add_modem(MODEM, T0)
    n.gateway.publish(MODEM, 10001, 20001)
    assert n.from_modem(MODEM, ev.TcpListen(10001), T0) == []  # not attached
    n.from_modem(MODEM, ev.Attach("internet"), T0)
    assert n.from_modem(MODEM, ev.TcpListen(10002), T0) == []  # not published
    (listen,) = n.from_modem(MODEM, ev.TcpListen(10001), T0)
    assert listen.port == 20001  # type: ignore[attr-defined]
    assert n.gateway.listening(MODEM) == [10001]
    n.from_modem(MODEM, ev.Detach(), T0)
    assert n.gateway.listening(MODEM) == []


def test_long_phone_sms_goes_concatenated() -> None:
    b = Bench()
    b.at("AT+CMGF=1")
    text = "".join(f"{i:03d}-" for i in range(60))  # 240 characters
    out = b.net(lambda n, t: n.phone_sms(PHONE, MODEM, text, t))
    assert out.line(MODEM) == b'\r\n+CMTI: "SM",1\r\n\r\n+CMTI: "SM",2\r\n'
    parts = [s for s in b.network.delivered(MODEM)]
    assert [len(p.text) for p in parts] == [153, 87]
    assert "".join(p.text for p in parts) == text
    assert [(p.concat.seq, p.concat.total) for p in parts if p.concat] == [(1, 2), (2, 2)]
    ucs2 = "č" * 100
    b.net(lambda n, t: n.phone_sms(PHONE, MODEM, ucs2, t))
    assert [len(p.text) for p in b.network.delivered(MODEM)[2:]] == [67, 33]
    pdu_listing = b.at("AT+CMGF=0;+CMGL=4")
    assert pdu_listing.count(b"+CMGL:") == 4
    # the HTTP API shows whole messages: complete concatenations joined
    assert [s.text for s in joined(b.network.delivered(MODEM))] == [text, ucs2]
    assert [s.text for s in joined(b.network.delivered(MODEM)[1:])] == [parts[1].text, ucs2]


def test_state_survives_a_restart() -> None:
    import json

    from sondalog.gsm import netstate

    b = Bench()
    b.at("AT+CFUN=0")
    b.network.set_credit(MODEM, 99.5)
    b.net(lambda n, t: n.phone_sms(PHONE, MODEM, "kept", t))
    b.net(lambda n, t: n.phone_sms(MODEM, PHONE2, "seen", t))
    saved = json.loads(json.dumps(netstate.dump(b.network)))
    # a new network process: same subscribers from the site file, state from disk
    fresh = Bench()
    out = fresh.system.network_call(netstate.load(fresh.network, saved, fresh.now), fresh.now)
    assert out.line(MODEM) == b'\r\n+CMTI: "SM",1\r\n'  # the new modem's radio is on
    assert [s.text for s in fresh.network.delivered(PHONE2)] == ["seen"]
    assert fresh.network.subscriber(MODEM).credit == 99.5
    assert fresh.network.phone_sms(PHONE, PHONE2, "x", fresh.now)[0].sms.sms_id == 3  # type: ignore[attr-defined]


def test_any_character_aborts_a_dial() -> None:
    b = Bench()
    other = Modem()
    b.system.add_modem("+420600000002", other, b.now)
    assert b.at("ATD+420600000002;") == b""
    assert b.send(b"x") == b"\r\nNO CARRIER\r\n"
    assert other.call is None and b.modem.call is None
