"""V.250 basics and 3GPP TS 27.007 commands of the modem: identification, echo and result
format, errors, registration, signal, radio, calls with caller id, USSD (gsm.md §2).

Each handler takes the modem, the command and ``now``; it returns information lines (the
line then ends ``OK``) or raises :class:`~sondalog.gsm.atline.CmeError`,
:class:`~sondalog.gsm.atline.AtSyntaxError` (``ERROR``) or
:class:`~sondalog.gsm.atline.Finish`.
"""

from __future__ import annotations

from sondalog.gsm import events as ev
from sondalog.gsm import modem_calls, wip
from sondalog.gsm.at_modem import (
    NO_NETWORK,
    NOT_ALLOWED,
    AtModem,
    Handler,
    Settings,
    handler_into,
    setting_value,
)
from sondalog.gsm.atline import (
    EXEC,
    NO_FINAL,
    READ,
    SET,
    TEST,
    AtCommand,
    AtSyntaxError,
    CmeError,
    Finish,
)
from sondalog.protocol import gsm7

HANDLERS: dict[str, Handler] = {}

_SPEEDS = (0, 300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)


handler = handler_into(HANDLERS)


def _flag(modem: AtModem, cmd: AtCommand, allowed: tuple[int, ...] = (0, 1)) -> int:
    value = int(cmd.args) if cmd.args else 0
    if value not in allowed:
        raise AtSyntaxError(f"{cmd.name}{value}")
    return value


# -- V.250 -------------------------------------------------------------------------------
@handler("E")
def _echo(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    m.settings.echo = bool(_flag(m, cmd))
    return []


@handler("V")
def _verbose(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    m.settings.verbose = bool(_flag(m, cmd))
    return []


@handler("Q")
def _quiet(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    m.settings.quiet = bool(_flag(m, cmd))
    return []


@handler("Z", "&F")
def _reset(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    m.settings = Settings()
    return []


@handler("&W", "&C", "&D", "&S", "&K", "X", "L", "M", "+IFC", "+ICF", "+WIND", "+CBST", "+CR")
@handler("+CRLP", "+CGDCONT", "+CMER", "+WOPEN", "+CPHS")
def _accepted(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    """Settings the simulation takes and ignores; their reads show what was set."""
    if cmd.kind == READ:
        value = m.settings.extra.get(cmd.name, "0")
        return [f"{cmd.name}: {value}"] if cmd.name.startswith("+") else []
    if cmd.kind == SET or (cmd.kind == EXEC and cmd.args):
        m.settings.extra[cmd.name] = cmd.args
    return []


@handler("S0")
def _s0(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"{m.settings.auto_answer:03d}"]
    m.settings.auto_answer = int(cmd.args or "0")
    return []


@handler("I", "+CGMM", "+GMM", "+CGMI", "+GMI", "+CGMR", "+GMR", "+CGSN", "+GSN", "+CIMI")
def _identify(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return []
    c = m.config
    if cmd.name == "I":
        return [{"": c.model, "0": c.model, "3": c.revision}.get(cmd.args, c.manufacturer)]
    key = cmd.name.replace("+C", "+")
    return [
        {"+GMM": c.model, "+GMI": c.manufacturer, "+GMR": c.revision, "+GSN": c.imei}.get(
            key, c.imsi
        )
    ]


@handler("+CMEE")
def _cmee(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CMEE: {m.settings.cmee}"]
    if cmd.kind == TEST:
        return ["+CMEE: (0,1)"]
    m.settings.cmee = setting_value(cmd, (0, 1)) if cmd.args else 0
    return []


@handler("+IPR")
def _ipr(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+IPR: {m.speed}"]
    if cmd.kind == TEST:
        return ["+IPR: (0,300,600,1200,2400,4800,9600,19200,38400,57600,115200)"]
    m.speed = setting_value(cmd, _SPEEDS) or m.speed
    return []


@handler("+CPIN")
def _cpin(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    """``+CPIN: READY`` without ``OK``: a Wavecom ends ``AT+CPIN?`` there (Multi-Tech's
    WIPsoft guide, "AT Command Syntax"; gammu expects it so)."""
    if cmd.kind == READ:
        raise Finish(NO_FINAL, ("+CPIN: READY",))
    return []


@handler("+CSCS")
def _cscs(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f'+CSCS: "{m.settings.charset}"']
    if cmd.kind == TEST:
        return ['+CSCS: ("GSM","IRA","UCS2","8859-1")']
    params = cmd.params()
    if len(params) != 1 or params[0].upper() not in ("GSM", "IRA", "UCS2", "8859-1"):
        raise CmeError(NOT_ALLOWED)
    m.settings.charset = params[0].upper()
    return []


# -- network: radio, registration, signal ------------------------------------------------
@handler("+CFUN")
def _cfun(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CFUN: {int(m.radio)}"]
    if cmd.kind == TEST:
        return ["+CFUN: (0,1),(0)"]
    on = bool(setting_value(cmd, (0, 1)))
    if on != m.radio:
        m.radio = on
        m.effect(ev.Radio(on))
        if not on:
            wip.drop_all(m)
            _set_registered(m, False)
            modem_calls.end_call(m, "NO CARRIER")
    return []


def _creg_stat(m: AtModem, n: int | None = None) -> str:
    """``<stat>``, and with ``AT+CREG=2`` the cell's ``"<lac>","<ci>"`` when registered."""
    stat = 1 if m.registered else (2 if m.radio else 0)
    if (m.settings.creg if n is None else n) == 2 and m.registered:
        return f'{stat},"{m.config.lac}","{m.config.cell}"'
    return str(stat)


@handler("+CGREG")
def _cgreg(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    """GPRS registration (27.007 §10.1.20): GPRS service follows GSM registration."""
    if cmd.kind == READ:
        return [f"+CGREG: {m.settings.cgreg},{_creg_stat(m, m.settings.cgreg)}"]
    if cmd.kind == TEST:
        return ["+CGREG: (0-2)"]
    m.settings.cgreg = setting_value(cmd, (0, 1, 2))
    return []


@handler("+CGATT")
def _cgatt(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    """GPRS attach state: attached while the WIPsoft GPRS bearer is started."""
    if cmd.kind == READ:
        return [f"+CGATT: {int(m.wip.started)}"]
    if cmd.kind == TEST:
        return ["+CGATT: (0,1)"]
    return []


@handler("+COPS")
def _cops(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    """Operator (27.007 §7.3): automatic selection; ``AT+COPS=3,<format>`` picks the name
    format shown (0 long name, 2 numeric)."""
    if cmd.kind == READ:
        if not m.registered:
            return ["+COPS: 0"]
        fmt = m.settings.cops_format
        name = m.config.operator_code if fmt == 2 else m.config.operator
        return [f'+COPS: 0,{fmt},"{name}"']
    if cmd.kind == TEST:
        c = m.config
        return [f'+COPS: (2,"{c.operator}","{c.operator}","{c.operator_code}"),,(0-4),(0-2)']
    values = cmd.ints(1, 3)
    if values[0] == 3 and len(values) > 1 and values[1] in (0, 1, 2):
        m.settings.cops_format = values[1]
    elif values[0] not in (0, 1, 2, 4):
        raise CmeError(NOT_ALLOWED)
    return []


@handler("+CREG")
def _creg(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CREG: {m.settings.creg},{_creg_stat(m)}"]
    if cmd.kind == TEST:
        return ["+CREG: (0-2)"]
    m.settings.creg = setting_value(cmd, (0, 1, 2))
    return []


@handler("+CSQ")
def _csq(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == TEST:
        return ["+CSQ: (0-31,99),(99)"]
    rssi = m.rssi if m.registered else 99
    return [f"+CSQ: {rssi},{0 if rssi != 99 else 99}"]


def _set_registered(m: AtModem, registered: bool) -> None:
    if registered == m.registered:
        return
    m.registered = registered
    if m.settings.creg:
        m.urc(f"+CREG: {_creg_stat(m)}")


# -- USSD --------------------------------------------------------------------------------
@handler("+CUSD")
def _cusd(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind == READ:
        return [f"+CUSD: {int(m.settings.cusd)}"]
    if cmd.kind == TEST:
        return ["+CUSD: (0,1,2)"]
    params = cmd.params()
    if not params or params[0] not in ("0", "1", "2"):
        raise CmeError(NOT_ALLOWED)
    m.settings.cusd = params[0] == "1"
    if len(params) > 1 and params[1]:
        if not m.registered:
            raise CmeError(NO_NETWORK)
        code = params[1]
        if m.settings.charset == "UCS2":  # 27.007 §7.15: <str> in the TE character set
            try:
                code = gsm7.decode_ucs2(bytes.fromhex(code))
            except ValueError:
                raise CmeError(NOT_ALLOWED) from None
        m.effect(ev.Ussd(code))
    return []


# -- events from the network -------------------------------------------------------------
def network_event(m: AtModem, event: ev.Event, now: float) -> None:
    if isinstance(event, ev.Registration):
        _set_registered(m, event.registered and m.radio)
        if not m.registered:
            wip.drop_all(m)
            modem_calls.end_call(m, "NO CARRIER")
    elif isinstance(event, ev.Signal):
        m.rssi = event.rssi if 0 <= event.rssi <= 31 else 99
    elif isinstance(event, ev.IncomingCall | ev.CallConnected | ev.CallEnded | ev.CallData):
        modem_calls.call_event(m, event, now)
    elif isinstance(event, ev.UssdAnswer):
        if not m.settings.cusd:
            return
        if event.text is None:
            m.urc("+CUSD: 4")
        else:
            text = event.text
            if m.settings.charset == "UCS2":
                text = gsm7.encode_ucs2(text).hex().upper()
            m.urc(f'+CUSD: 0,"{text}",15')
