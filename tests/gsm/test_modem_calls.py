"""Calls on the modem: caller id, extended ring, data mode, ``+++`` (gsm.md §2, §6)."""

from __future__ import annotations

from gsm_helpers import MODEM, PHONE, PHONE2, Bench

from sondalog.gsm import events as ev


def ring(b: Bench, kind: str, caller: str = PHONE) -> tuple[int, bytes]:
    call_id, items = b.network.phone_call(caller, MODEM, kind, b.now)
    return call_id, b.system.network_call(items, b.now).line(MODEM)


def test_voice_call_with_caller_id_is_hung_up() -> None:
    b = Bench()
    b.at("AT+CLIP=1;+CRC=1")
    call_id, out = ring(b, ev.VOICE)
    assert out == b'\r\n+CRING: VOICE\r\n\r\n+CLIP: "+420700000001",145\r\n'
    assert b.modem.next_deadline() == b.now + 5
    assert b.later(5) == b'\r\n+CRING: VOICE\r\n\r\n+CLIP: "+420700000001",145\r\n'
    assert b.at("ATH") == b"\r\nOK\r\n"
    assert [(p.kind, p.call_id) for p in b.last.phones] == [("ended", call_id)]
    assert b.later(10) == b""


def test_plain_ring_without_crc_and_clip() -> None:
    b = Bench()
    _, out = ring(b, ev.DATA)
    assert out == b"\r\nRING\r\n"
    b.at("AT+CRC=1")
    assert b.later(5) == b"\r\n+CRING: REL ASYNC\r\n"


def test_data_call_session_and_escape() -> None:
    b = Bench()
    call_id, _ = ring(b, ev.DATA)
    assert b.at("ATA") == b"\r\nCONNECT 9600\r\n"
    assert [(p.kind, p.call_id) for p in b.last.phones] == [("answered", call_id)]
    # the far end types a command, the modem passes it to the DTE and back
    assert b.net(lambda n, t: n.phone_data(call_id, b"read com speed\r")).line(MODEM) == (
        b"read com speed\r"
    )
    b.send(b"\r\n9600\r\nOK\r\n")
    assert [p.data for p in b.last.phones] == [b"\r\n9600\r\nOK\r\n"]
    # '+++' right after data is data, not an escape
    b.send(b"+++")
    assert [p.data for p in b.last.phones] == [b"+++"]
    # '+++' after the guard but followed by data within 1 s is data too
    b.later(1.0)
    b.send(b"+++")
    assert [p.data for p in b.last.phones] == []
    assert b.later(0.5) == b""
    b.send(b"x")
    assert [p.data for p in b.last.phones] == [b"+++x"]
    # after 1 s of silence, '+++' then 1 s of silence: online command mode
    b.later(1.0)
    assert b.send(b"+++") == b""
    assert b.modem.next_deadline() == b.now + 1.0
    assert b.later(1.0) == b"\r\nOK\r\n"
    # the far end's data waits until ATO
    b.net(lambda n, t: n.phone_data(call_id, b"held"))
    assert b.at("AT+CSQ") == b"\r\n+CSQ: 18,0\r\n\r\nOK\r\n"
    assert b.at("ATO") == b"\r\nCONNECT 9600\r\nheld"
    # the far end hangs up
    assert b.net(lambda n, t: n.phone_hang_up(call_id, t)).line(MODEM) == b"\r\nNO CARRIER\r\n"
    assert b.at("AT") == b"\r\nOK\r\n"


def test_ath_from_online_command_mode() -> None:
    b = Bench()
    ring(b, ev.DATA)
    b.at("ATA")
    b.later(1.5)
    b.send(b"+++")
    assert b.later(1.0) == b"\r\nOK\r\n"
    assert b.at("ATH") == b"\r\nOK\r\n"
    assert [(p.kind, p.reason) for p in b.last.phones] == [("ended", "hangup")]


def test_auto_answer_after_two_rings() -> None:
    b = Bench()
    assert b.at("ATS0=2") == b"\r\nOK\r\n"
    _, out = ring(b, ev.DATA)
    assert out == b"\r\nRING\r\n"
    assert b.later(5) == b"\r\nRING\r\n"
    assert b.later(5) == b"\r\nCONNECT 9600\r\n"


def test_caller_gives_up_and_no_answer() -> None:
    b = Bench()
    call_id, _ = ring(b, ev.VOICE)
    assert b.net(lambda n, t: n.phone_hang_up(call_id, t)).line(MODEM) == b""
    assert b.at("ATA") == b"\r\nNO CARRIER\r\n"
    call_id, _ = ring(b, ev.VOICE)
    b.later(60)
    assert [(p.kind, p.reason) for p in b.last.phones] == [("ended", "no answer")]
    assert b.modem.call is None


def test_second_caller_is_busy_and_unreachable_when_radio_off() -> None:
    b = Bench()
    ring(b, ev.VOICE)
    _, items = b.network.phone_call(PHONE2, MODEM, ev.VOICE, b.now)
    assert [(p.kind, p.reason) for p in items] == [("ended", "busy")]  # type: ignore[attr-defined]
    b.at("ATH;+CFUN=0")
    _, items = b.network.phone_call(PHONE2, MODEM, ev.VOICE, b.now)
    assert [(p.kind, p.reason) for p in items] == [("ended", "unreachable")]  # type: ignore[attr-defined]


def test_modem_dials() -> None:
    b = Bench()
    assert b.at(f"ATD{PHONE};") == b"\r\nOK\r\n"
    assert b.at("ATH") == b"\r\nOK\r\n"
    assert b.at(f"ATD{PHONE}") == b"\r\nNO CARRIER\r\n"  # a phone takes no data call
    assert b.at("ATD+420999999999;") == b"\r\nNO CARRIER\r\n"
