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

import ipaddress
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from sondalog.config import Table
from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import DEFAULT_USSD, Network
from sondalog.gsm.sms import DEFAULT_SMSC, normalize
from sondalog.gsm.system import GsmSystem

#: ``model(modem, key, number)``: the value at the start of a model table given for a
#: modem's ``signal`` or ``credit`` (``app/gsm_site.py``: the served world's models).
Model = Callable[[Table, str, str], float]


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


def phone_number(t: Table, key: str, default: str | None = None) -> str:
    """The E.164 number ``t[key]`` (``00420 ...`` normalized to ``+420...``)."""
    what = "a phone number in quotes"
    value = t.text(key, what=what) if default is None else t.text(key, default, what=what)
    number = normalize(value)
    if not (number.startswith("+") and number[1:].isdigit() and 4 <= len(number) <= 16):
        raise t.fail(key, f"{value!r} is not an E.164 number like +420600000001")
    return number


def entries(t: Table, key: str, keys: Iterable[str] | None = None) -> list[Table]:
    """``[[gsm.KEY]]`` tables (a single ``[gsm.KEY]`` table counts as one), each checked to
    hold only ``keys`` if given."""
    return [t.table(key, keys)] if t.is_table(key) else t.tables(key, keys)


def _ipv4(value: str) -> str:
    try:
        return str(ipaddress.IPv4Address(value))
    except ValueError:
        raise ValueError(f"must be an IPv4 address in quotes, not {value!r}") from None


def _port(t: Table, key: str) -> int:
    """The port a ``publish`` key names (TOML keys are strings)."""
    if not key.isdigit() or not 1 <= int(key) <= 65535:
        raise t.fail(None, f"{key!r} is not a port number (1..65535)")
    return int(key)


def _ussd(m: Table) -> dict[str, str]:
    ussd = dict(DEFAULT_USSD)
    answers = m.table("ussd")
    for code in answers:
        text = answers.text(code, what="text", empty=True)
        try:
            text.format(credit=0.0)
        except (KeyError, IndexError, ValueError) as exc:
            raise answers.fail(code, f"bad placeholder: {exc}") from None
        ussd[code] = text
    return ussd


def _value(m: Table, key: str, number: str, model: Model | None) -> float | None:
    """A model's value at the start if ``m[key]`` is a model table (and models are allowed)."""
    return model(m, key, number) if model is not None and m.is_table(key) else None


def _modem(m: Table, number: str, smsc: Callable[[], str], model: Model | None) -> ModemSpec:
    signal = _value(m, "signal", number, model)
    rssi = m.integer("signal", 18) if signal is None else round(signal)
    if not (0 <= rssi <= 31 or rssi == 99):
        raise m.fail("signal", f"must be 0..31 (or 99, unknown), not {rssi}")
    publish_table = m.table("publish")
    publish = {
        _port(publish_table, k): publish_table.integer(k, lo=1, hi=65535, what="a port 1..65535")
        for k in publish_table
    }
    ussd = _ussd(m)
    defaults = ModemConfig()
    config = ModemConfig(
        store_size=m.integer("store_size", 30, lo=1, hi=255),
        imei=m.text("imei", defaults.imei),
        imsi=m.text("imsi", defaults.imsi),
        smsc=smsc(),
    )
    credit = _value(m, "credit", number, model)
    if credit is None:
        credit = m.number("credit", 0.0)
    return ModemSpec(number, credit, rssi, publish, ussd, config)


def parse(
    table: Table,
    *,
    keys: Iterable[str] = (),
    modem_keys: Iterable[str] = (),
    model: Model | None = None,
) -> GsmConfig:
    """Check a ``[gsm]`` table; raises :class:`~sondalog.config.ConfigError` naming the file,
    line and field. ``keys`` and ``modem_keys`` are further keys allowed in ``[gsm]`` and in
    each ``[[gsm.modem]]`` (what serving adds); with ``model``, a modem's ``signal`` or
    ``credit`` may be a model table (``model`` gives its value at the start)."""
    table.keys(_TOP | set(keys))
    hosts_table = table.table("hosts")
    hosts = {name.lower(): hosts_table.convert(name, _ipv4) for name in hosts_table}
    parsed_smsc: list[str] = []  # parsed once, where it is first needed (the errors' order)

    def smsc() -> str:
        if not parsed_smsc:
            parsed_smsc.append(phone_number(table, "smsc", DEFAULT_SMSC))
        return parsed_smsc[0]

    seen: set[str] = set()

    def subscriber(t: Table) -> str:
        number = phone_number(t, "number")
        if number in seen:
            raise t.fail("number", f"{number} is already a subscriber")
        seen.add(number)
        return number

    modems = [
        _modem(m, subscriber(m), smsc, model)
        for m in entries(table, "modem", _MODEM | set(modem_keys))
    ]
    phones = [subscriber(p) for p in entries(table, "phone", {"number"})]
    outages = []
    for o in entries(table, "outage", {"start", "end", "number"}):
        start, end = o.number("start"), o.number("end")
        if end <= start:
            raise o.fail("end", "must be after start")
        target = phone_number(o, "number") if "number" in o else None
        if target is not None and target not in seen:
            raise o.fail("number", f"{target} is not a subscriber")
        outages.append((start, end, target))
    return GsmConfig(
        smsc=smsc(),
        sms_price=table.number("sms_price", 0.0),
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
