"""Calls on the modem (3GPP TS 27.007 §6-§7, V.250 §6.3): caller id ``+CLIP``, extended ring
``+CRC`` (``+CRING: VOICE``, ``+CRING: REL ASYNC``), ``ATA``, ``ATD``, ``ATH``, ``ATO``,
auto-answer ``ATS0``, ``NO CARRIER`` (gsm.md §2, manual §3.4.6.3, §6.10.2.3-4).
"""

from __future__ import annotations

from sondalog.gsm import events as ev
from sondalog.gsm.at_modem import (
    ActiveCall,
    AtModem,
    Handler,
    handler_into,
    number_type,
    setting_value,
)
from sondalog.gsm.atline import READ, TEST, AtCommand, Finish

HANDLERS: dict[str, Handler] = {}
handler = handler_into(HANDLERS)

#: Seconds between two ``RING``.
RING_PERIOD = 5.0


@handler("+CLIP")
def _clip(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CLIP: {int(m.settings.clip)},1"]
    if cmd.kind == TEST:
        return ["+CLIP: (0,1)"]
    m.settings.clip = bool(setting_value(cmd, (0, 1)))
    return []


@handler("+CRC")
def _crc(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CRC: {int(m.settings.crc)}"]
    if cmd.kind == TEST:
        return ["+CRC: (0,1)"]
    m.settings.crc = bool(setting_value(cmd, (0, 1)))
    return []


@handler("A")
def _answer(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    call = m.call
    if call is None or not call.incoming or call.active:
        raise Finish("NO CARRIER")
    answer(m, now)
    raise Finish(None)


def answer(m: AtModem, now: float) -> None:
    """Take the ringing call: ``OK`` for voice, ``CONNECT <rate>`` and data mode for data."""
    call = m.call
    assert call is not None
    call.active = True
    call.next_ring = None
    m.effect(ev.Answer())
    _connected(m, call, now)


def _connected(m: AtModem, call: ActiveCall, now: float) -> None:
    """The call is up: ``CONNECT <rate>`` and data mode for data, ``OK`` for voice."""
    if call.kind == ev.DATA:
        m.final(f"CONNECT {m.config.data_rate}")
        m.enter_data_mode(None, now)
    else:
        m.final("OK")


@handler("D")
def _dial(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    text = cmd.args.strip()
    voice = text.endswith(";")
    number = "".join(ch for ch in text.rstrip(";") if ch.isdigit() or ch in "+*#")
    if not number or (text[:1].upper() == "L"):
        raise Finish("ERROR")
    if m.call is not None:
        raise Finish("BUSY")
    if not m.registered:
        raise Finish("NO CARRIER")
    kind = ev.VOICE if voice else ev.DATA
    m.call = ActiveCall(kind, number, incoming=False)
    m.effect(ev.Dial(number, kind))
    raise Finish(None)


@handler("H", "+CHUP")
def _hang_up(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return []
    if m.call is not None:
        m.effect(ev.HangUp())
        m.call = None
        m.drop_held_data()
    return []


@handler("O")
def _online(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if m.call is None or not m.call.active or m.call.kind != ev.DATA:
        raise Finish("NO CARRIER")
    _connected(m, m.call, now)
    raise Finish(None)


def end_call(m: AtModem, result: str | None) -> None:
    call = m.call
    if call is None:
        return
    m.call = None
    if m.mode == "data" and m.data_target is None:
        m.leave_data_mode()
    m.drop_held_data()
    if result and (call.active or not call.incoming):
        m.urc(result)


def ring_timer(m: AtModem, now: float) -> None:
    call = m.call
    if call is None or call.next_ring is None or now < call.next_ring:
        return
    if m.settings.auto_answer and call.rings >= m.settings.auto_answer:
        answer(m, now)
        return
    _ring(m, now)


def _ring(m: AtModem, now: float) -> None:
    call = m.call
    assert call is not None
    if m.settings.crc:
        m.urc("+CRING: VOICE" if call.kind == ev.VOICE else "+CRING: REL ASYNC")
    else:
        m.urc("RING")
    if m.settings.clip:
        number = call.caller or ""
        m.urc(f'+CLIP: "{number}",{number_type(number)}')
    call.rings += 1
    call.next_ring = now + RING_PERIOD


def call_event(m: AtModem, event: ev.Event, now: float) -> None:
    """Call events from the network."""
    if isinstance(event, ev.IncomingCall):
        if m.call is not None or not m.registered:
            m.effect(ev.HangUp())  # busy
            return
        m.call = ActiveCall(event.kind, event.caller, incoming=True)
        _ring(m, now)
    elif isinstance(event, ev.CallConnected):
        call = m.call
        if call is None or call.incoming:
            return
        call.active = True
        _connected(m, call, now)
    elif isinstance(event, ev.CallEnded):
        call = m.call
        if call is not None and not call.incoming and not call.active:
            m.call = None
            m.final({"busy": "BUSY", "no answer": "NO ANSWER"}.get(event.reason, "NO CARRIER"))
        else:
            end_call(m, "NO CARRIER")
    elif isinstance(event, ev.CallData) and m.call is not None and m.call.active:
        m.far_data(event.data)
