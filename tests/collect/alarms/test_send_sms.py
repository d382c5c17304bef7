"""SMS notifications (issue 21): the PDU and AT conversation of a modem line (pure), and for
real: the served GSM network (``sondalog serve`` with [gsm]) through its HTTP API and
through its modem's pty, the SMS checked at the receiving phone."""

from __future__ import annotations

import asyncio
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from sondalog.collect.alarms import Message, Notify
from sondalog.collect.alarms.modem_sms import (
    MAX_BUFFER,
    Conversation,
    ModemError,
    one_sms,
    submit_pdu,
)
from sondalog.collect.alarms.send_sms import (
    ModemSms,
    ModemSmsSettings,
    NetworkSms,
    NetworkSmsSettings,
    sms_text,
)
from sondalog.collect.alarms.senders import DeliveryError, sender_for
from sondalog.gsm import pdu

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gsm"))
from gsm_served import MODEM, PHONE, PHONE2, Served, free_port, serve, site_file


def message(text: str = "F01/1 Air above 40: 41.5", what: str = "raised") -> Message:
    return Message(
        key=f"a1-1/{what}/sms",
        destination="sms",
        what=what,  # type: ignore[arg-type]
        event="a1-1",
        text=text,
        created=0.0,
        next_try=0.0,
    )


# -- pure: one SMS, the PDU, the conversation ----------------------------------------------


def test_a_long_text_is_cut_to_one_sms() -> None:
    assert one_sms("short") == ("short", True)
    cut, gsm = one_sms("x" * 200)
    assert gsm and len(cut) == 160 and cut.endswith("x...")
    cut, _ = one_sms("€" * 100)  # an extension character takes two septets
    assert cut == "€" * 78 + "..."
    cut, gsm = one_sms("Kč" * 50)  # č is not GSM-7: UCS2, 70 characters
    assert not gsm and len(cut) == 70 and cut.endswith("...")
    assert sms_text(message("hot", "cleared")) == "CLEARED: hot"


@pytest.mark.parametrize("text", ["hi", "x" * 160, "€[] 5 °C", "Kč 5 € ✓"])
def test_the_pdu_is_an_sms_submit(text: str) -> None:
    hex_pdu, length = submit_pdu(PHONE, text)
    raw = bytes.fromhex(hex_pdu)
    assert pdu.tpdu_length(raw) == length
    decoded = pdu.decode_submit(raw)
    assert (decoded.destination, decoded.text, decoded.smsc) == (PHONE, text, None)
    national = pdu.decode_submit(bytes.fromhex(submit_pdu("12345", "a")[0]))
    assert national.destination == "12345"


def test_the_conversation_sends_to_every_number() -> None:
    talk = Conversation((PHONE, PHONE2), "hot")
    assert talk.start() == b"\x1bAT\r"
    assert talk.receive(b"AT\r\r\nO") == b""  # echo, half an answer
    assert talk.receive(b"K\r\n") == b"ATE0\r"
    assert talk.receive(b"ATE0\r\r\nOK\r\n") == b"AT+CMGF=0\r"
    hex_pdu, length = submit_pdu(PHONE, "hot")
    assert talk.receive(b"\r\nOK\r\n") == f"AT+CMGS={length}\r".encode()
    assert talk.receive(b"\r\n> ") == hex_pdu.encode() + b"\x1a"
    assert talk.receive(b"\r\n+CMGS: 7\r\n\r\nOK\r\n") == f"AT+CMGS={length}\r".encode()
    assert talk.receive(b"\r\n> ") == submit_pdu(PHONE2, "hot")[0].encode() + b"\x1a"
    assert not talk.done
    assert talk.receive(b"\r\n+CMGS: 8\r\n\r\nOK\r\n") == b""
    assert talk.done and talk.references == [7, 8]


@pytest.mark.parametrize("answer", [b"\r\n+CMS ERROR: 331\r\n", b"\r\nERROR\r\n"])
def test_a_refusal_ends_the_conversation(answer: bytes) -> None:
    talk = Conversation((PHONE,), "hot")
    talk.start()
    for reply in (b"OK\r\n", b"OK\r\n", b"OK\r\n"):
        talk.receive(reply)
    with pytest.raises(ModemError, match=r"AT\+CMGS=.*ERROR"):
        talk.receive(answer)


def test_the_read_buffer_is_bounded() -> None:
    talk = Conversation((PHONE,), "hot")
    talk.start()
    talk.receive(b"x" * MAX_BUFFER)
    with pytest.raises(ModemError, match="no answer"):
        talk.receive(b"x")


def test_ok_without_a_reference_is_an_error() -> None:
    talk = Conversation((PHONE,), "hot")
    talk.start()
    for reply in (b"OK\r\n", b"OK\r\n", b"OK\r\n", b"> "):
        talk.receive(reply)
    with pytest.raises(ModemError, match="without \\+CMGS"):
        talk.receive(b"\r\nOK\r\n")


# -- for real: the served GSM network ------------------------------------------------------


@pytest.fixture
def world(tmp_path: Path) -> Iterator[Served]:
    site, _ = site_file(tmp_path)
    served = serve(site, tmp_path / "state")
    try:
        yield served
    finally:
        if served.proc.poll() is None:
            served.stop()


def inbox(world: Served, number: str) -> list[tuple[str, str]]:
    return [(m["from"], m["text"]) for m in world.request("GET", f"/sms?to={number}")[1]]


def test_sms_through_the_network_api(world: Served) -> None:
    notify = Notify("sms", "sms", NetworkSmsSettings(world.api, PHONE, (PHONE2, MODEM)))
    sender = sender_for(notify)
    assert isinstance(sender, NetworkSms)
    asyncio.run(sender.send(message()))
    assert inbox(world, PHONE2) == [(PHONE, "ALARM: F01/1 Air above 40: 41.5")]
    assert inbox(world, MODEM) == [(PHONE, "ALARM: F01/1 Air above 40: 41.5")]
    bad = Notify("x", "sms", NetworkSmsSettings(world.api, PHONE, ("+1",)))
    with pytest.raises(DeliveryError, match=r"SMS to \+1"):
        asyncio.run(sender_for(bad).send(message()))
    gone = Notify(
        "x", "sms", NetworkSmsSettings(f"http://127.0.0.1:{free_port()}", PHONE, (PHONE2,))
    )
    with pytest.raises(DeliveryError, match="cannot reach"):
        asyncio.run(sender_for(gone).send(message()))


def test_sms_through_the_served_modem_pty(world: Served) -> None:
    pty = next(x for x in world.lines if x.startswith("gsm modem pty")).split()[3]
    notify = Notify("pager", "sms", ModemSmsSettings(Path(pty), (PHONE2,)))
    sender = sender_for(notify)
    assert isinstance(sender, ModemSms)
    long = "F01/1 Air above 40: " + "very hot " * 30

    async def run() -> None:
        await sender.send(message())
        await sender.send(message(long, "repeat"))
        await sender.close()

    asyncio.run(run())
    got = inbox(world, PHONE2)
    assert got[0] == (MODEM, "ALARM: F01/1 Air above 40: 41.5")
    assert got[1][0] == MODEM and len(got[1][1]) == 160
    assert got[1][1] == ("ALARM: " + long)[:157] + "..."
    assert len(got) == 2 and sender.references == sorted(sender.references)


def test_a_missing_modem_is_a_delivery_error(tmp_path: Path) -> None:
    notify = Notify("pager", "sms", ModemSmsSettings(tmp_path / "ttyNONE", (PHONE2,)))
    with pytest.raises(DeliveryError, match="ttyNONE"):
        asyncio.run(sender_for(notify).send(message()))
