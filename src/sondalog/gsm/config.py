"""A GSM world described as data (a site file's ``[gsm]`` table), checked and built.

The runtime reads the site file; this module turns its ``[gsm]`` table into a
:class:`~sondalog.gsm.system.GsmSystem` without I/O, naming the field of any mistake::

    [gsm]
    smsc = "+420603052000"
    sms_price = 0.0                       # credit taken per SMS a modem sends
    hosts = { "smtp.example.net" = "127.0.0.1", "pop3.example.net" = "127.0.0.1" }

    [[gsm.modem]]
    number = "+420600000001"
    credit = 250.0
    signal = 18                           # +CSQ rssi 0..31
    publish = { "10001" = 20001 }         # modem port -> host port on 127.0.0.1
    ussd = { "*101#" = "Your credit is {credit:.2f} CZK." }
    store_size = 30

    [[gsm.phone]]
    number = "+420700000001"

    [[gsm.outage]]                        # POSIX seconds; number absent: everyone
    start = 1764464400
    end = 1764468000
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import DEFAULT_USSD, Network
from sondalog.gsm.sms import DEFAULT_SMSC, normalize
from sondalog.gsm.system import GsmSystem


class GsmConfigError(ValueError):
    """A wrong ``[gsm]`` table: ``field`` is the dotted path of the mistake."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field


@dataclass(frozen=True, slots=True)
class ModemSpec:
    number: str
    credit: float = 0.0
    signal: int = 18
    publish: dict[int, int] = field(default_factory=dict)
    ussd: dict[str, str] = field(default_factory=lambda: dict(DEFAULT_USSD))
    config: ModemConfig = field(default_factory=ModemConfig)


@dataclass(frozen=True, slots=True)
class GsmConfig:
    smsc: str = DEFAULT_SMSC
    sms_price: float = 0.0
    hosts: dict[str, str] = field(default_factory=dict)
    modems: tuple[ModemSpec, ...] = ()
    phones: tuple[str, ...] = ()
    outages: tuple[tuple[float, float, str | None], ...] = ()


_TOP = {"smsc", "sms_price", "hosts", "modem", "phone", "outage"}
_MODEM = {"number", "credit", "signal", "publish", "ussd", "store_size", "imei", "imsi"}


def _known(table: Mapping[str, Any], keys: set[str], where: str) -> None:
    for key in table:
        if key not in keys:
            raise GsmConfigError(
                f"{where}.{key}", f"unknown key (known: {', '.join(sorted(keys))})"
            )


def _number(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise GsmConfigError(where, "must be a phone number in quotes")
    number = normalize(value)
    if not (number.startswith("+") and number[1:].isdigit() and 4 <= len(number) <= 16):
        raise GsmConfigError(where, f"{value!r} is not an E.164 number like +420600000001")
    return number


def _get(table: Mapping[str, Any], key: str, kind: type, default: Any, where: str) -> Any:
    value = table.get(key, default)
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool) != (kind is bool):
        raise GsmConfigError(f"{where}.{key}", f"must be {kind.__name__}")
    return value


def _port(value: Any, where: str) -> int:
    try:
        port = int(value)
    except (TypeError, ValueError):
        raise GsmConfigError(where, f"{value!r} is not a port number") from None
    if not 1 <= port <= 65535:
        raise GsmConfigError(where, f"{port} is not a port number (1..65535)")
    return port


def _tables(value: Any, where: str) -> list[Mapping[str, Any]]:
    if isinstance(value, Mapping):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
        raise GsmConfigError(where, "must be a table or an array of tables")
    return value


def parse(table: Mapping[str, Any], where: str = "gsm") -> GsmConfig:
    """Check a ``[gsm]`` table; raises :class:`GsmConfigError` naming the field."""
    _known(table, _TOP, where)
    hosts_raw = _get(table, "hosts", dict, {}, where)
    hosts = {}
    for name, ip in hosts_raw.items():
        if not isinstance(ip, str) or len(ip.split(".")) != 4:
            raise GsmConfigError(f"{where}.hosts.{name}", "must be an IPv4 address in quotes")
        hosts[str(name).lower()] = ip
    parsed_smsc: list[str] = []  # parsed once, where it is first needed (the errors' order)

    def smsc() -> str:
        if not parsed_smsc:
            parsed_smsc.append(_number(table.get("smsc", DEFAULT_SMSC), f"{where}.smsc"))
        return parsed_smsc[0]

    seen: set[str] = set()

    def unique(number: str, at: str) -> str:
        if number in seen:
            raise GsmConfigError(at, f"{number} is already a subscriber")
        seen.add(number)
        return number

    modems = []
    for i, m in enumerate(_tables(table.get("modem", []), f"{where}.modem")):
        at = f"{where}.modem[{i}]"
        _known(m, _MODEM, at)
        number = unique(_number(m.get("number"), f"{at}.number"), f"{at}.number")
        signal = _get(m, "signal", int, 18, at)
        if not (0 <= signal <= 31 or signal == 99):
            raise GsmConfigError(f"{at}.signal", "must be 0..31 (or 99, unknown)")
        publish = {
            _port(k, f"{at}.publish"): _port(v, f"{at}.publish.{k}")
            for k, v in _get(m, "publish", dict, {}, at).items()
        }
        ussd = dict(DEFAULT_USSD)
        for code, text in _get(m, "ussd", dict, {}, at).items():
            if not isinstance(text, str):
                raise GsmConfigError(f"{at}.ussd.{code}", "must be text")
            try:
                text.format(credit=0.0)
            except (KeyError, IndexError, ValueError) as exc:
                raise GsmConfigError(f"{at}.ussd.{code}", f"bad placeholder: {exc}") from None
            ussd[str(code)] = text
        size = _get(m, "store_size", int, 30, at)
        if not 1 <= size <= 255:
            raise GsmConfigError(f"{at}.store_size", "must be 1..255")
        defaults = ModemConfig()
        modem_config = ModemConfig(
            store_size=size,
            imei=_get(m, "imei", str, defaults.imei, at),
            imsi=_get(m, "imsi", str, defaults.imsi, at),
            smsc=smsc(),
        )
        credit = _get(m, "credit", float, 0.0, at)
        modems.append(ModemSpec(number, credit, signal, publish, ussd, modem_config))
    phones = []
    for i, p in enumerate(_tables(table.get("phone", []), f"{where}.phone")):
        at = f"{where}.phone[{i}]"
        _known(p, {"number"}, at)
        phones.append(unique(_number(p.get("number"), f"{at}.number"), f"{at}.number"))
    outages = []
    for i, o in enumerate(_tables(table.get("outage", []), f"{where}.outage")):
        at = f"{where}.outage[{i}]"
        _known(o, {"start", "end", "number"}, at)
        start = _get(o, "start", float, None, at)
        end = _get(o, "end", float, None, at)
        if end <= start:
            raise GsmConfigError(f"{at}.end", "must be after start")
        target = _number(o["number"], f"{at}.number") if "number" in o else None
        if target is not None and target not in seen:
            raise GsmConfigError(f"{at}.number", f"{target} is not a subscriber")
        outages.append((start, end, target))
    return GsmConfig(
        smsc=smsc(),
        sms_price=_get(table, "sms_price", float, 0.0, where),
        hosts=hosts,
        modems=tuple(modems),
        phones=tuple(phones),
        outages=tuple(outages),
    )


def build(
    config: GsmConfig,
    now: float,
    trace: Callable[[str], Callable[[str, bytes, float], None] | None] | None = None,
) -> GsmSystem:
    """The world ``config`` describes; ``trace(number)`` may give each modem a trace hook.
    The modems' power-up output is dropped (no line is attached yet)."""
    network = Network(smsc=config.smsc, sms_price=config.sms_price)
    network.gateway.hosts.update(config.hosts)
    system = GsmSystem(network)
    for phone in config.phones:
        network.add_phone(phone)
    for spec in config.modems:
        modem = Modem(spec.config, trace=trace(spec.number) if trace else None)
        system.add_modem(
            spec.number, modem, now, credit=spec.credit, rssi=spec.signal, ussd=dict(spec.ussd)
        )
        for port, host_port in spec.publish.items():
            network.gateway.publish(spec.number, port, host_port)
    for start, end, target in config.outages:
        network.schedule_outage(start, end, target)
    return system
