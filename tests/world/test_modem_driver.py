"""The logger's modem driver against the simulated modem and network (pure, stepped clock)."""

from __future__ import annotations

from gsm_world import LOGGER, PHONE, World

from sondalog.ala1.outbox import Destination


def test_setup_registers_and_sends_an_sms() -> None:
    w = World()
    w.run(5)
    assert w.driver.present is True
    saw = w.modem_saw()
    for cmd in (b"ATE0\r", b"AT+CMEE=1\r", b"AT+CMGF=1\r", b"AT+CLIP=1\r", b"AT+CRC=1\r"):
        assert cmd in saw
    ident = w.send("read com speed\r\n9600\r\nOK\r\n", Destination("sms", PHONE))
    w.run(5)
    assert w.done == [(ident, True)]
    assert w.sms_to(PHONE) == ["read com speed\r\n9600\r\nOK\r\n"]


def test_long_reply_split_and_non_gsm7_characters() -> None:
    w = World()
    w.run(5)
    body = "t°C " + "x" * 196 + "\r\nOK\r\n"
    ident = w.send(body, Destination("sms", PHONE))
    w.run(5)
    assert w.done == [(ident, True)]
    parts = w.sms_to(PHONE)
    assert [len(p) for p in parts] == [160, len(body) - 160]
    assert "".join(parts) == body.replace("°", "?")


def test_no_coverage_fails_then_a_retry_goes() -> None:
    w = World()
    w.run(5)
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, False, w.now), w.now))
    first = w.send("first", Destination("sms", PHONE))
    w.run(90)
    assert w.done == [(first, False)]
    assert w.sms_to(PHONE) == []
    w.collect(w.site.network_call(lambda n: n.set_coverage(LOGGER, True, w.now), w.now))
    second = w.send("first", Destination("sms", PHONE))
    w.run(10)
    assert w.done[-1] == (second, True)
    assert w.sms_to(PHONE) == ["first"]


def test_sms_command_answered_by_sms_byte_exact() -> None:
    w = World()
    w.run(5)
    w.phone_sms("please ##*#read com speed##*# thanks")
    w.run(5)
    assert w.sms_to(PHONE) == ["9600\r\nOK\r\n"]
    assert b"AT+CMGD=1\r" in w.modem_saw()


def test_sms_without_boundary_is_deleted_and_ignored() -> None:
    w = World()
    w.run(5)
    w.phone_sms("read com speed")
    w.run(5)
    assert w.sms_to(PHONE) == []
    assert b"AT+CMGR=1\r" in w.modem_saw() and b"AT+CMGD=1\r" in w.modem_saw()
