"""Every configurable setting of an ALA1 (§6.1, factory values of §11), as the host names it.

A :class:`Setting` ties a parameter of the logger (``channel {ch} sampling period``) to its
place in a station file (``[channel.N]`` ``sampling_period``), its grammar
(:mod:`sondalog.client.station_grammar`), factory value and manual section. :data:`SETTINGS`
is in the order the manual explains them, which is also the order of a station file;
:data:`APPLY_ORDER` is the order writes are made in (spec notes §6: memory partition first;
tables before the channels that use them; ``i address`` last, §6.3.8).

Not settings (state, not configuration): ``date``, ``record last N read`` (moved by reads),
``output N value`` is a setting (a switch held on or off), ``com device mode`` is the same
parameter as ``com device`` (spec notes §5), read-only parameters and actions.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from decimal import Decimal

from sondalog.client.station_grammar import (
    BAUD_RATES,
    TOTAL_MEMORY,
    ChannelAddress,
    Choice,
    Date,
    Format,
    Grammar,
    Integer,
    IntList,
    Limits,
    MemorySize,
    Number,
    OneOf,
    OutputValue,
    Period,
    RestOfLine,
    Text,
)

#: Index placeholder of each numbered group and its count.
INDEX: dict[str, tuple[str, Callable[[Limits], int]]] = {
    "device": ("dev", lambda lim: lim.devices),
    "channel": ("ch", lambda lim: lim.channels),
    "output": ("out", lambda lim: lim.outputs),
    "command": ("cmd", lambda lim: lim.commands),
    "address": ("adr", lambda lim: lim.addresses),
    "message": ("msg", lambda lim: lim.messages),
}
#: Factory device calibration per device type (§6.4.4; spec notes §7).
FACTORY_CAL = {"MSP430ADC": ("2.5", "0"), "MSP430TA": ("1", "0"), "DS18B20": ("3276.8", "0")}

#: A factory value: fixed text, or computed from the desired values, the instance's number
#: and the logger's serial number.
Default = str | Callable[[Mapping[str, str], int, str], str]
#: Where a number's read-back format comes from: a fixed format or another setting's key.
FormatOf = Callable[[Mapping[str, str], int], str]


@dataclass(frozen=True)
class Setting:
    """One configurable parameter of the logger."""

    pattern: str  # the logger's keywords, {dev}/{ch}/... for the group's number
    group: str  # station-file table: "channel" (numbered: [channel.N]) or "com.network"
    key: str  # station-file key
    grammar: Grammar
    default: Default
    section: str
    dual: bool = False  # two inputs (§6.5.12.2): read and written with ``all``
    fmt: FormatOf | None = None  # numbers: the format they read back in
    note: str = ""  # said in the plan when the write has a side effect

    @property
    def numbered(self) -> bool:
        return "{" in self.pattern

    def name(self, n: int) -> str:
        """The logger's name of instance ``n`` (``channel 3 sampling period``)."""
        if not self.numbered:
            return self.pattern
        return self.pattern.replace("{" + INDEX[self.group][0] + "}", str(n))

    def count(self, limits: Limits) -> int:
        return INDEX[self.group][1](limits) if self.numbered else 1

    def default_for(self, values: Mapping[str, str], n: int, serial: str) -> str:
        base = self.default(values, n, serial) if callable(self.default) else self.default
        return f"{base},{base}" if self.dual else base


def _fixed(fmt: str) -> FormatOf:
    return lambda values, n: fmt


def _own(key: str) -> FormatOf:
    return lambda values, n: values[key.format(ch=n)]


def _watched(values: Mapping[str, str], n: int) -> str:
    channel = values[f"message {n} of channel number"]
    return values[f"channel {channel} format"]


def _device_cal(which: int) -> Default:
    return lambda values, n, serial: FACTORY_CAL[values[f"device {n} type"]][which]


def _serial(values: Mapping[str, str], n: int, serial: str) -> str:
    return serial


def _settings() -> list[Setting]:
    S = Setting
    u16 = 65535
    ch = "channel {ch} "
    msg = "message {msg} "
    return [
        # §6.3 i: identity strings (i address last of all: it guards every later command)
        S("i name", "identity", "name", Text(20), "", "6.3.5"),
        S("i description", "identity", "description", Text(20), _serial, "6.3.6"),
        S("i type", "identity", "type", Text(20), _serial, "6.3.7"),
        S("i address", "identity", "address", Text(10), "", "6.3.8",
          note="from now on every command needs iaddress, §8.6.1"),
        # §6.4 devices
        S("device {dev} type", "device", "type",
          Choice(("MSP430ADC", "MSP430TA", "DS18B20")), "MSP430ADC", "6.4.1",
          note="restores its factory calibration, §6.4.4.3"),
        S("device {dev} address", "device", "address", Integer(0, u16), "0", "6.4.2"),
        S("device {dev} cal mult", "device", "cal_mult", Number(), _device_cal(0), "6.4.4.1",
          fmt=_fixed("0.6")),
        S("device {dev} cal add", "device", "cal_add", Number(), _device_cal(1), "6.4.4.2",
          fmt=_fixed("0.6")),
        # §6.5 channels
        S("channel max number", "channel", "max_number",
          Integer(1, lambda lim: lim.channels), "1", "6.5.1"),
        S(ch + "name", "channel", "name", Text(20), "Supply[V]", "6.5.3"),
        S(ch + "type", "channel", "type", OneOf((1, 2, 3, 6, 9, 11, 12)), "1", "6.5.6"),
        S(ch + "device", "channel", "device", Integer(0, 8), "1", "6.5.4", dual=True),
        S(ch + "address", "channel", "address", ChannelAddress(), "21", "6.5.5", dual=True),
        S(ch + "format", "channel", "format", Format(), "0.1", "6.5.7"),
        S(ch + "cal mult format", "channel", "cal_mult_format", Format(), "0.0", "6.5.10.3.2"),
        S(ch + "cal mult value", "channel", "cal_mult", Number(), "1", "6.5.10.1",
          fmt=_own("channel {ch} cal mult format")),
        S(ch + "cal add format", "channel", "cal_add_format", Format(), "0.0", "6.5.10.3.2"),
        S(ch + "cal add value", "channel", "cal_add", Number(), "0", "6.5.10.2",
          fmt=_own("channel {ch} cal add format")),
        S(ch + "cal2 mult", "channel", "cal2_mult", Number(), "1", "6.5.11", dual=True,
          fmt=_fixed("0.6")),
        S(ch + "cal2 add", "channel", "cal2_add", Number(), "0", "6.5.11", dual=True,
          fmt=_fixed("0.6")),
        S(ch + "convert 1 file name", "channel", "table1", Text(10), "", "6.5.12.1"),
        S(ch + "convert 2 file name", "channel", "table2", Text(10), "", "6.5.12.1"),
        S(ch + "switch output", "channel", "switch_output", Integer(0, 7), "1", "6.5.13.1",
          dual=True),
        S(ch + "switch advance", "channel", "switch_advance", Integer(0, u16), "1",
          "6.5.13.2", dual=True),
        S(ch + "sampling period", "channel", "sampling_period", Period(), "000000", "6.5.14.1"),
        S(ch + "sampling start", "channel", "sampling_start", Date(), "20000101000000",
          "6.5.14.2"),
        S(ch + "average samples", "channel", "average_samples", Integer(0, u16), "0",
          "6.5.15"),
        S(ch + "record change", "channel", "record_change",
          Number(lo=Decimal(0), special=(Decimal(-1),)), "0", "6.5.16.1",
          fmt=_own("channel {ch} format")),
        S(ch + "record samples", "channel", "record_samples", Integer(0, u16), "0",
          "6.5.16.2"),
        # §6.6 record
        S("record type", "record", "type", Choice(("CYCLIC", "LINEAR")), "CYCLIC", "6.6.4",
          note="only while the record is empty"),
        # §6.7 outputs
        S("output {out} device", "output", "device", Integer(0, 8),
          lambda v, n, s: "1" if n == 1 else "0", "6.7.1"),
        S("output {out} address", "output", "address", Integer(0, u16),
          lambda v, n, s: "7" if n == 1 else "0", "6.7.2"),
        S("output {out} value", "output", "value", OutputValue(), "NO", "6.7.3"),
        # §6.8 named commands, §6.9
        S("command {cmd} name", "command", "name", Text(20), "", "6.8.2"),
        S("command {cmd} value", "command", "value", Text(100), "", "6.8.3"),
        S("command channel switch hold", "command", "switch_hold", Period(), "000005", "6.9"),
        # §6.10 addresses
        S("address {adr} type", "address", "type",
          Choice(("SMS", "EMAIL", "RINGVOICE", "RINGDATA"),
                 (("RINGVOICE", lambda lim: lim.messages),
                  ("RINGDATA", lambda lim: lim.messages))), "SMS", "6.10.2"),
        S("address {adr} value", "address", "value", Text(), "", "6.10.3"),
        # §6.11 com
        S("com speed", "com", "speed", OneOf(BAUD_RATES), "9600", "6.11.2",
          note="the serial line changes speed"),
        S("com max speed", "com", "max_speed", OneOf(BAUD_RATES), "230400", "6.11.3"),
        S("com transmitter mode", "com", "transmitter_mode",
          Choice(("SAVING", "FOLLOW", "ON")), "SAVING", "6.11.4"),
        S("com device", "com", "device",
          Choice(("LOCAL", "WAVECOM40", "WAVECOM41", "WAVECOM42")), "LOCAL", "6.11.5"),
        S("com network smc", "com.network", "smsc", Text(), "", "6.11.6.1"),
        S("com network apn address", "com.network", "apn", Text(), "", "6.11.6.2"),
        S("com network smtp address", "com.network", "smtp", Text(), "", "6.11.6.3"),
        S("com network pop3 address", "com.network", "pop3", Text(), "", "6.11.6.4.1"),
        S("com network pop3 size", "com.network", "pop3_size", Integer(0, 10_000_000),
          "10000", "6.11.6.4.2"),
        S("com network pop3 time", "com.network", "pop3_time", Integer(0, u16), "120",
          "6.11.6.4.3"),
        S("com network delay", "com.network", "delay", Integer(0, u16), "0", "6.11.6.5"),
        S("com status sim credit code", "com", "sim_credit_code", RestOfLine(), "", "6.11.7"),
        # §6.12 sms, §6.13 e-mail
        S("sms command boundary", "sms", "command_boundary", Text(10), "##*#", "6.12.1"),
        S("sms email address start", "sms", "email_address_start", Text(10), "startemail",
          "6.12.2.1"),
        S("sms email address end", "sms", "email_address_end", Text(10), "endemail",
          "6.12.2.2"),
        S("email send from", "email", "from", Text(), "", "6.13.1"),
        S("email send subject", "email", "subject", Text(20), "", "6.13.2"),
        # §6.14 messages
        S(msg + "address", "message", "address", IntList(), "1", "6.14.2"),
        S(msg + "command", "message", "command", Integer(1, lambda lim: lim.commands), "1",
          "6.14.3"),
        S(msg + "period", "message", "period", Period(month=True), "000000", "6.14.4"),
        S(msg + "start", "message", "start", Date(), "20000101000000", "6.14.5"),
        S(msg + "of record function", "message", "on_record", Choice(("YES", "NO")), "NO",
          "6.14.6.1"),
        S(msg + "of channel function", "message", "on_channel", Choice(("NO", "UP", "DOWN")),
          "NO", "6.14.7.1"),
        S(msg + "of channel number", "message", "channel",
          Integer(1, lambda lim: lim.channels), "1", "6.14.7.2"),
        S(msg + "of channel value", "message", "value", Number(), "0", "6.14.7.3",
          fmt=_watched),
        S(msg + "of channel hysteresis", "message", "hysteresis", Number(lo=Decimal(0)), "0",
          "6.14.7.4", fmt=_watched),
        # §6.15 memory partition
        S("file record size", "file", "record_size", MemorySize(minimum=256),
          str(TOTAL_MEMORY), "6.15.1", note="erases the record and the tables, §6.15.1"),
        S("file list size", "file", "list_size", MemorySize(), "0", "6.15.2"),
        S("file data size", "file", "data_size", MemorySize(), "0", "6.15.3"),
        # §6.17
        S("global timing", "global", "timing", OneOf((8, 64, 4096)), "8", "6.17.2"),
    ]  # fmt: skip


SETTINGS: list[Setting] = _settings()
BY_PATTERN = {s.pattern: s for s in SETTINGS}
#: Manual sections of the groups of a station file.
GROUP_SECTIONS = {
    "identity": ("6.3", "identity (i)"),
    "device": ("6.4", "devices"),
    "channel": ("6.5", "channels"),
    "record": ("6.6", "record"),
    "output": ("6.7", "outputs and switches"),
    "command": ("6.8", "named commands"),
    "address": ("6.10", "addresses"),
    "com": ("6.11", "communication"),
    "com.network": ("6.11.6", "GSM network"),
    "sms": ("6.12", "SMS"),
    "email": ("6.13", "e-mail"),
    "message": ("6.14", "messages"),
    "file": ("6.15", "memory partition"),
    "global": ("6.17", "global"),
}

#: Ranks of groups written before the others (the rest keep the manual's order): the memory
#: partition first (§6.15.1 erases the record and zeroes the other areas), then devices, then
#: the record type while no channel has sampled into the record yet.
_FIRST = {"file": 0, "device": 1, "record": 2}
_LAST = ("com max speed", "com transmitter mode", "com device", "com speed", "i address")


def _apply_rank(setting: Setting) -> int:
    if setting.pattern in _LAST:
        return 100 + _LAST.index(setting.pattern)
    return _FIRST.get(setting.group, 10)


#: The order writes are made in; conversion tables go right after the memory partition.
APPLY_ORDER: list[Setting] = sorted(SETTINGS, key=_apply_rank)


def instances(limits: Limits) -> list[tuple[Setting, int]]:
    """Every instance of every setting for a logger with ``limits``, in file order."""
    out: list[tuple[Setting, int]] = []
    for setting in SETTINGS:
        out.extend((setting, n) for n in range(1, setting.count(limits) + 1))
    return out
