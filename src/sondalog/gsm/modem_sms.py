"""SMS commands of the modem (3GPP TS 27.005 §3-§4): text and PDU mode, store ``"SM"``.

``AT+CMGF`` selects the mode; ``AT+CMGS`` sends (``> `` prompt, text or PDU hex, Ctrl-Z sends,
ESC cancels); a delivered SMS is stored and announced ``+CMTI: "SM",<index>``; ``AT+CMGR``,
``AT+CMGL`` read, ``AT+CMGD`` deletes; ``AT+CPMS``, ``AT+CSCA``, ``AT+CSMP``, ``AT+CNMI``
(gsm.md §2, recipes.md §5 for the exchange gammu drives).
"""

from __future__ import annotations

from sondalog.gsm import events as ev
from sondalog.gsm import pdu
from sondalog.gsm.at_modem import AtModem, Handler, number_type
from sondalog.gsm.atline import READ, TEST, AtCommand, AtSyntaxError, CmsError, Finish
from sondalog.gsm.smsstore import ALL, STAT_NUMBER, STAT_TEXT, STO_SENT, STO_UNSENT, StoredSms
from sondalog.protocol import gsm7

HANDLERS: dict[str, Handler] = {}

#: CMS error codes (27.005 §3.2.5).
OPERATION_NOT_ALLOWED = 302
INVALID_PDU = 304
INVALID_TEXT = 305
INVALID_INDEX = 321
MEMORY_FULL = 322
NO_NETWORK = 331


def cmgf(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CMGF: {int(m.settings.text_mode)}"]
    if cmd.kind == TEST:
        return ["+CMGF: (0,1)"]
    values = cmd.ints(1, 1)
    if values[0] not in (0, 1):
        raise CmsError(OPERATION_NOT_ALLOWED)
    m.settings.text_mode = values[0] == 1
    return []


def csca(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f'+CSCA: "{m.smsc}",{number_type(m.smsc)}']
    if cmd.kind == TEST:
        return []
    params = cmd.params()
    if not params or not params[0]:
        raise CmsError(OPERATION_NOT_ALLOWED)
    m.smsc = params[0]
    return []


def csmp(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return ["+CSMP: " + ",".join(str(v) for v in m.settings.csmp)]
    if cmd.kind == TEST:
        return []
    values = [v if v is not None else 0 for v in cmd.ints(1, 4)]
    m.settings.csmp = tuple(values + list(m.settings.csmp[len(values) :]))
    return []


def cnmi(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return ["+CNMI: " + ",".join(str(v) for v in m.settings.cnmi)]
    if cmd.kind == TEST:
        return ["+CNMI: (0-3),(0-3),(0-3),(0-2),(0,1)"]
    values = [v if v is not None else 0 for v in cmd.ints(1, 5)]
    m.settings.cnmi = tuple(values + list(m.settings.cnmi[len(values) :]))
    return []


def cpms(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    used, total = len(m.store), m.store.capacity
    if cmd.kind == READ:
        return [f'+CPMS: "SM",{used},{total},"SM",{used},{total},"SM",{used},{total}']
    if cmd.kind == TEST:
        return ['+CPMS: (("SM"),("SM"),("SM"))']
    params = cmd.params()
    if not params or any(p.upper() != "SM" for p in params):
        raise CmsError(OPERATION_NOT_ALLOWED)
    return [f"+CPMS: {used},{total},{used},{total},{used},{total}"]


def cmgs(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return []
    params = cmd.params()
    if not params or not params[0]:
        raise AtSyntaxError("AT+CMGS needs a parameter")
    if m.settings.text_mode:
        m.sms_destination = params[0]
    else:
        if not params[0].isdigit() or not 1 <= int(params[0]) <= 164:
            raise CmsError(INVALID_PDU)
        m.sms_length = int(params[0])
    m.start_sms_input()
    raise Finish(None)


def submit(m: AtModem, body: bytes, now: float) -> None:
    """Ctrl-Z ended the SMS text or PDU: send it, answer ``+CMGS: <mr>`` or the error."""
    try:
        sms = _text_sms(m, body) if m.settings.text_mode else _pdu_sms(m, body)
        if not m.registered:
            raise CmsError(NO_NETWORK)
    except CmsError as error:
        m.final(m.error_text(error))
        return
    mr = m.next_mr()
    m.effect(ev.SendSms(sms.to, sms.text, mr, sms.alphabet, sms.concat))
    m.info(f"+CMGS: {mr}")
    m.final("OK")


def _text_sms(m: AtModem, body: bytes) -> ev.SendSms:
    if m.settings.charset == "UCS2":
        try:
            text = gsm7.decode_ucs2(bytes.fromhex(body.decode("ascii")))
        except ValueError as exc:
            raise CmsError(INVALID_TEXT) from exc
    else:
        text = body.decode("latin-1")
    try:
        alphabet = pdu.alphabet_of(m.settings.csmp[3])
    except pdu.PduError as exc:
        raise CmsError(INVALID_TEXT) from exc
    if alphabet == pdu.UCS2:
        if len(gsm7.encode_ucs2(text)) > pdu.MAX_USER_DATA:
            raise CmsError(INVALID_TEXT)
    else:
        alphabet = pdu.GSM7
        text = gsm7.to_gsm7(text)
        if gsm7.septet_length(text) > gsm7.SMS_SEPTETS:
            raise CmsError(INVALID_TEXT)
    return ev.SendSms(m.sms_destination, text, 0, alphabet)


def _pdu_sms(m: AtModem, body: bytes) -> ev.SendSms:
    hex_text = "".join(chr(b) for b in body if chr(b) not in " \r\n")
    try:
        raw = pdu.from_hex(hex_text)
        if not raw or pdu.tpdu_length(raw) != m.sms_length:
            raise CmsError(INVALID_PDU)
        sms = pdu.decode_submit(raw)
    except pdu.PduError as exc:
        raise CmsError(INVALID_PDU) from exc
    if not sms.destination:
        raise CmsError(INVALID_PDU)
    return ev.SendSms(sms.destination, sms.text, 0, sms.alphabet, sms.concat)


def delivered(m: AtModem, event: ev.SmsDelivered) -> None:
    """The network delivers an SMS: store it and announce it, or refuse it (store full)."""
    index = m.store.add(
        StoredSms(event.sender, event.text, event.timestamp, event.alphabet, event.concat)
    )
    if index is None:
        m.effect(ev.SmsRejected(event.sms_id))
        return
    m.effect(ev.SmsAccepted(event.sms_id))
    if m.settings.cnmi[1] != 0:
        m.urc(f'+CMTI: "SM",{index}')


def _index(m: AtModem, cmd: AtCommand) -> int:
    values = cmd.ints(1, 2)
    index = values[0]
    if index is None or not m.store.in_range(index):
        raise CmsError(INVALID_INDEX)
    return index


def cmgr(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return []
    index = _index(m, cmd)
    sms = m.store.get(index)
    if sms is None:
        raise CmsError(INVALID_INDEX)
    lines = _show(m, sms, None)
    m.store.mark_read(index)
    return lines


def cmgl(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    text_mode = m.settings.text_mode
    if cmd.kind == TEST:
        return (
            ['+CMGL: ("REC UNREAD","REC READ","STO UNSENT","STO SENT","ALL")']
            if text_mode
            else ["+CMGL: (0-4)"]
        )
    params = cmd.params()
    which = params[0].upper() if params else ("REC UNREAD" if text_mode else "0")
    if text_mode:
        stat = STAT_NUMBER.get(which)
    else:
        stat = int(which) if which.isdigit() and int(which) in STAT_TEXT else None
    if stat is None:
        raise CmsError(OPERATION_NOT_ALLOWED)
    lines: list[str] = []
    for index, sms in m.store.listing(stat):
        lines += _show(m, sms, index)
        m.store.mark_read(index)
    return lines


def _show(m: AtModem, sms: StoredSms, index: int | None) -> list[str]:
    """``+CMGR``/``+CMGL`` header line and body for one SMS."""
    prefix = "+CMGR: " if index is None else f"+CMGL: {index},"
    if m.settings.text_mode:
        stamp = _scts_text(sms.timestamp, m.config.tz_quarters)
        head = f'{prefix}"{STAT_TEXT[sms.status]}","{sms.sender}",,"{stamp}"'
        return [head, _text_body(m, sms.text)]
    raw = pdu.encode_deliver(
        sms.sender,
        sms.text,
        sms.timestamp,
        tz_quarters=m.config.tz_quarters,
        smsc=m.smsc,
        alphabet=sms.alphabet if gsm7.is_gsm7(sms.text) else pdu.UCS2,
        concat=sms.concat,
    )
    return [f"{prefix}{sms.status},,{pdu.tpdu_length(raw)}", raw.hex().upper()]


def _text_body(m: AtModem, text: str) -> str:
    if m.settings.charset == "UCS2":
        return gsm7.encode_ucs2(text).hex().upper()
    return text.encode("latin-1", "replace").decode("latin-1")


def _scts_text(posix: int, tz_quarters: int) -> str:
    """``yy/MM/dd,hh:mm:ss±zz`` (27.005 §3.3.6 ``<scts>`` in text mode)."""
    y, mo, d, h, mi, s = pdu._gmtime(posix + tz_quarters * 900)
    return f"{y % 100:02d}/{mo:02d}/{d:02d},{h:02d}:{mi:02d}:{s:02d}{tz_quarters:+03d}"


def cmgd(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return [f"+CMGD: (1-{m.store.capacity}),(0-4)"]
    values = cmd.ints(1, 2)
    flag = values[1] if len(values) > 1 and values[1] is not None else 0
    was_full = m.store.full
    if flag == 0:
        m.store.delete(_index(m, cmd))
    elif flag in (1, 2, 3, 4):
        statuses = {1: {1}, 2: {1, STO_SENT}, 3: {1, STO_SENT, STO_UNSENT}, 4: set(range(ALL))}
        m.store.delete_where(statuses[flag])
    else:
        raise CmsError(OPERATION_NOT_ALLOWED)
    if was_full and not m.store.full:
        m.effect(ev.StoreAvailable())
    return []


HANDLERS.update(
    {
        "+CMGF": cmgf,
        "+CSCA": csca,
        "+CSMP": csmp,
        "+CNMI": cnmi,
        "+CPMS": cpms,
        "+CMGS": cmgs,
        "+CMGR": cmgr,
        "+CMGL": cmgl,
        "+CMGD": cmgd,
    }
)
