"""The logger's modem driver against the simulated modem and network (pure, stepped clock)."""

from __future__ import annotations

from gsm_world import PHONE, World

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

