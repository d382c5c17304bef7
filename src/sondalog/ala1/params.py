"""The ALA1 parameter tree (§6.1, §11) declared once as data (DESIGN.md point 3).

Every leaf of the keyword tree is one :class:`Leaf`: its keyword pattern, value type, access,
factory value (§11), manual section and, where a parameter does more than store a value, the
behaviour that runs on read or write. Parsing, read/write, factory reset and the generated
reference (``docs/protocol.md``) all come from :data:`LEAVES`.

Patterns are keyword words with index placeholders:

``{dev}`` device 1..8, ``{out}`` output 1..7, ``{cmd}`` command, ``{adr}`` address,
``{msg}`` message (optional, default 1), ``{ch}`` channel list (optional, default all
channels 1..``channel max number``), ``{tab}`` table 1|2 (optional, default 1), ``{pt}`` last
read point 1..4 (optional, default 1), ``{n}`` number of record rows (optional, default 1).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal

from sondalog.ala1.model import (
    BAUD_RATES,
    TOTAL_MEMORY,
    CommandError,
    Limits,
    Version,
    View,
)
from sondalog.ala1.record import row_key
from sondalog.ala1.tokens import NumberFormat, ParseError, format_stamp
from sondalog.ala1.values import (
    ChannelAddress,
    Choice,
    Date,
    Format,
    Indices,
    Integer,
    IntList,
    MemorySize,
    NoValue,
    Number,
    OneOf,
    OptionalInteger,
    OutputValue,
    Period,
    RestOfLine,
    Text,
    TextRow,
    ValueType,
    fixed,
)

Default = str | Callable[[View, Indices], str]
#: A computed read: the data lines of the answer (``read nothing`` answers none).
Reader = Callable[[View, Indices, str | None], list[str]]
#: A write with side effects: receives the parsed values (two for ``all``).
Writer = Callable[[View, Indices, list[str]], None]
#: A write that takes one value for all its targets (``write channel 1 3 value 5``).
GroupWriter = Callable[[View, list[Indices], list[str]], None]


@dataclass(frozen=True)
class IndexSpec:
    """An index that follows a keyword: ``device 3``, ``channel 1 3``, ``message``."""

    name: str
    hi: Callable[[Limits], int]
    optional: bool = False
    default: int = 1
    is_list: bool = False
    lo: int = 1
    doc: str = ""


INDEX_SPECS: dict[str, IndexSpec] = {
    "dev": IndexSpec("dev", lambda lim: lim.devices, doc="device 1..8"),
    "out": IndexSpec("out", lambda lim: lim.outputs, doc="output 1..7"),
    "cmd": IndexSpec("cmd", lambda lim: lim.commands, doc="command 1..4 (1.16) / 1..40 (2.10)"),
    "adr": IndexSpec("adr", lambda lim: lim.addresses, doc="address 1..8 / 1..40"),
    "msg": IndexSpec(
        "msg", lambda lim: lim.messages, optional=True, doc="message 1..2 / 1..40, default 1"
    ),
    "ch": IndexSpec(
        "ch",
        lambda lim: lim.channels,
        optional=True,
        is_list=True,
        doc="channel list, default all channels",
    ),
    "tab": IndexSpec("tab", lambda lim: 2, optional=True, doc="table 1 or 2, default 1"),
    "pt": IndexSpec("pt", lambda lim: 4, optional=True, doc="last-read point 1..4, default 1"),
    "n": IndexSpec(
        "n", lambda lim: 10_000_000, optional=True, lo=0, doc="at most n rows, default 1"
    ),
}


@dataclass(frozen=True)
class Leaf:
    """One parameter (or action) of the tree."""

    pattern: str
    vtype: ValueType
    access: str  # "R", "W" or "RW"
    default: Default
    section: str
    doc: str
    dual: bool = False  # two inputs with ``all`` (§6.5.12.2)
    hexable: bool = False  # ``x`` reads/writes hexadecimal (§6.5.5.2)
    aliases: tuple[str, ...] = ()
    reader: Reader | None = None
    writer: Writer | None = None
    read_arg: ValueType | None = None  # a read that takes a parameter (``read text/s/``)
    unavailable: str | None = None  # behaviour arrives with a later issue: error response
    ends_line: bool = False  # nothing may follow on the line (§7: ``write global reset``)
    stored: bool = True  # has a storage key
    default_doc: str = ""  # the factory value in words, when it depends on other values
    group_writer: GroupWriter | None = None  # one value for all targets

    @property
    def words(self) -> tuple[str, ...]:
        return tuple(self.pattern.split())

    def key(self, indices: Indices, slot: int = 1) -> str:
        """The storage key of one instance: the pattern with its indices filled in."""
        key = self.pattern.format(**indices)
        return key if slot == 1 else f"{key} #{slot}"

    def default_for(self, view: View, indices: Indices) -> str:
        return self.default(view, indices) if callable(self.default) else self.default


# -- behaviours ------------------------------------------------------------------------------


def _channel_format(view: View, indices: Indices) -> NumberFormat:
    return NumberFormat.parse(view.get(f"channel {indices['ch']} format"))


def _own_format(which: str) -> Callable[[View, Indices], NumberFormat]:
    def fmt(view: View, indices: Indices) -> NumberFormat:
        return NumberFormat.parse(view.get(f"channel {indices['ch']} cal {which} format"))

    return fmt


def _message_channel_format(view: View, indices: Indices) -> NumberFormat:
    channel = int(view.get(f"message {indices['msg']} of channel number"))
    return NumberFormat.parse(view.get(f"channel {channel} format"))


#: Factory device calibration per device type (§6.4.4; sondalog decision for MSP430ADC:
#: the internal 2.5 V reference of the MSP430F149 and no offset).
FACTORY_CAL: dict[str, tuple[str, str]] = {
    "MSP430ADC": ("2.5", "0"),
    "MSP430TA": ("1", "0"),
    "DS18B20": ("3276.8", "0"),
}


def _device_cal_default(which: int) -> Default:
    def default(view: View, indices: Indices) -> str:
        return FACTORY_CAL[view.get(f"device {indices['dev']} type")][which]

    return default


def _write_device_type(view: View, indices: Indices, values: list[str]) -> None:
    """§6.4.4.3: choosing a device type restores its factory calibration."""
    dev = indices["dev"]
    view.set(f"device {dev} type", values[0])
    mult, add = FACTORY_CAL[values[0]]
    view.set(f"device {dev} cal mult", mult)
    view.set(f"device {dev} cal add", add)


def _read_date(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [format_stamp(view.now())]


def _write_date(view: View, indices: Indices, values: list[str]) -> None:
    from sondalog.ala1.tokens import parse_stamp

    view.set_clock(parse_stamp(values[0]))


def _identity(attr: str) -> Reader:
    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        ident = view.identity
        value = {
            "version": ident.version.value,
            "device": ident.device,
            "snumber": ident.serial_number,
            "program": ident.program,
        }[attr]
        return [value]

    return read


def _serial_number(view: View, indices: Indices) -> str:
    return view.identity.serial_number


def _program(view: View, indices: Indices) -> str:
    return view.identity.program


def _limit(attr: str) -> Reader:
    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        return [str(getattr(view.identity.limits, attr))]

    return read


_COM_MODES = {"WAVECOM40": "SAVING", "WAVECOM41": "GSM", "WAVECOM42": "GPRS"}


def _read_com_mode(view: View, indices: Indices, arg: str | None) -> list[str]:
    device = view.get("com device")
    if device == "LOCAL":
        raise CommandError("com mode needs a wavecom device (§6.11.5.3)")
    return [_COM_MODES[device]]


def _write_com_mode(view: View, indices: Indices, values: list[str]) -> None:
    if view.get("com device") == "LOCAL":
        raise CommandError("com mode needs a wavecom device (§6.11.5.3)")
    device = {mode: dev for dev, mode in _COM_MODES.items()}[values[0]]
    view.set("com device", device)


def _sizes(view: View) -> tuple[int, int, int]:
    return (
        int(view.get("file record size")),
        int(view.get("file list size")),
        int(view.get("file data size")),
    )


def _write_record_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.1: written first; zeroes the list and data areas and clears the record."""
    view.set("file record size", values[0])
    view.set("file list size", "0")
    view.set("file data size", "0")
    view.clear_record()


def _write_list_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.2: written second; zeroes the data area."""
    record, _, _ = _sizes(view)
    if record + int(values[0]) > TOTAL_MEMORY:
        raise CommandError("the areas exceed the memory")
    view.set("file list size", values[0])
    view.set("file data size", "0")


def _write_data_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.3: written last."""
    record, listing, _ = _sizes(view)
    if record + listing + int(values[0]) > TOTAL_MEMORY:
        raise CommandError("the areas exceed the memory")
    view.set("file data size", values[0])


def _read_free_size(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [str(TOTAL_MEMORY - sum(_sizes(view)))]


def _read_record_space(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [str(TOTAL_MEMORY)]


def _read_record_status(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.record.status()]


def _write_record_type(view: View, indices: Indices, values: list[str]) -> None:
    """§6.6.4: the type can change only while the record is empty."""
    if len(view.record) and values[0] != view.get("record type"):
        raise CommandError("the record type changes only while the record is empty")
    view.set("record type", values[0])


def _start_of(view: View, point: str) -> int:
    """§6.6.1: with the ``.c`` counter, rows after that row; without, from the oldest row
    at or after the point; an empty point is before the oldest row."""
    if not point:
        return 0
    if "." in point:
        return view.record.position_after(point)
    return view.record.position_at_or_after(point)


def _read_record_from_date(view: View, indices: Indices, arg: str | None) -> list[str]:
    return view.record.rows(_start_of(view, arg or ""), indices["n"])


def _read_record_from_start(view: View, indices: Indices, arg: str | None) -> list[str]:
    return view.record.rows(0, indices["n"])


def _read_record_from_last(shift: bool) -> Reader:
    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        key = f"record last {indices['pt']} read"
        rows = view.record.rows(_start_of(view, view.get(key)), indices["n"])
        if shift and rows:
            view.set(key, row_key(rows[-1]))
        return rows

    return read


def _read_value(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.measure(indices["ch"])]


def _write_values(view: View, targets: list[Indices], values: list[str]) -> None:
    """§6.5.8: measure the channels now and store them as one row of type t (default 2)."""
    count = int(view.get("channel max number"))
    fields = [""] * max(count, max(t["ch"] for t in targets))
    for target in targets:
        fields[target["ch"] - 1] = view.measure(target["ch"])
    view.append_row(int(values[0]) if values else 2, ",".join(fields[:count]))


def _read_sample(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.channel_state(indices["ch"])[0]]


def _read_recorded(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.channel_state(indices["ch"])[1]]


def _write_text(view: View, indices: Indices, values: list[str]) -> None:
    """§6.19: the string becomes a row ``stamp,t,s`` (type 3 unless given)."""
    row_type, _, text = values[0].partition(",")
    view.append_row(int(row_type), text)


def _write_record_clear(view: View, indices: Indices, values: list[str]) -> None:
    view.clear_record()
    for point in range(1, 5):
        view.set(f"record last {point} read", "")


def _write_global_reset(view: View, indices: Indices, values: list[str]) -> None:
    """§6.17.1: factory values except the three communication parameters; record erased."""
    view.reset(keep=("com speed", "com device", "com transmitter mode"))
    view.clear_record()


def _transfer(area: str) -> Reader:
    """§6.16: the module sends the area by XMODEM after the command."""

    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        view.start_transfer(area, reading=True)
        return []

    return read


def _transfer_in(area: str) -> Writer:
    """§6.16: the module receives the area by XMODEM after the command."""

    def write(view: View, indices: Indices, values: list[str]) -> None:
        view.start_transfer(area, reading=False)

    return write


def _read_nothing(view: View, indices: Indices, arg: str | None) -> list[str]:
    return []


def _write_nothing(view: View, indices: Indices, values: list[str]) -> None:
    return None


def _read_text(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [arg or ""]


def _write_com_close(view: View, indices: Indices, values: list[str]) -> None:
    """§6.11.8: release the line so that messages may be sent (§6.14.9.2)."""
    view.release_line()


# -- the tree --------------------------------------------------------------------------------

_channels: Callable[[Limits], int] = lambda lim: lim.channels  # noqa: E731
_messages: Callable[[Limits], int] = lambda lim: lim.messages  # noqa: E731
_commands: Callable[[Limits], int] = lambda lim: lim.commands  # noqa: E731
_addresses: Callable[[Limits], int] = lambda lim: lim.addresses  # noqa: E731
_U16 = 65535

LATER_MESSAGES = "messages (a later issue)"


def _leaves() -> list[Leaf]:
    L = Leaf
    S = "§"
    ch = "channel {ch}"
    return [
        # §6.2 date
        L("date", Date(), "RW", "", S + "6.2", "module clock", reader=_read_date,
          writer=_write_date, stored=False),
        # §6.3 i
        L("i version", NoValue(), "R", "", S + "6.3.1", "protocol version",
          reader=_identity("version"), stored=False),
        L("i device", NoValue(), "R", "", S + "6.3.2", "hardware version",
          reader=_identity("device"), stored=False),
        L("i snumber", NoValue(), "R", "", S + "6.3.3", "serial number",
          reader=_identity("snumber"), stored=False, default_doc="--serial-number, 000001"),
        L("i program", Text(40), "R", _program, S + "6.3.4",
          "program version (changed by an upgrade, §6.16.4)", default_doc="sondalog VERSION"),
        L("i name", Text(20), "RW", "", S + "6.3.5", "module name for messages"),
        L("i description", Text(20), "RW", _serial_number, S + "6.3.6", "module label",
          default_doc="the serial number"),
        L("i type", Text(20), "RW", _serial_number, S + "6.3.7", "configuration type",
          default_doc="the serial number"),
        L("i address", Text(10), "RW", "", S + "6.3.8", "own address / password"),
        # §6.4 device
        L("device {dev} type", Choice(("MSP430ADC", "MSP430TA", "DS18B20")), "RW",
          "MSP430ADC", S + "6.4.1", "device type; restores factory calibration",
          writer=_write_device_type),
        L("device {dev} address", Integer(0, _U16), "RW", "0", S + "6.4.2",
          "P6 bit of a DS18B20"),
        L("device {dev} cal mult", Number(), "RW", _device_cal_default(0), S + "6.4.4.1",
          "device multiplicative calibration",
          default_doc="by type: MSP430ADC 2.500000, MSP430TA 1.000000, DS18B20 3276.800000"),
        L("device {dev} cal add", Number(), "RW", _device_cal_default(1), S + "6.4.4.2",
          "device additive calibration", default_doc="0.000000 for every type"),
        # §6.5 channel
        L("channel max number", Integer(1, _channels), "RW", "1", S + "6.5.1",
          "number of channels"),
        L(ch + " name", Text(20), "RW", "Supply[V]", S + "6.5.3", "channel name"),
        L(ch + " device", Integer(0, 8), "RW", "1", S + "6.5.4", "input device (0 = none)",
          dual=True),
        L(ch + " address", ChannelAddress(), "RW", "21", S + "6.5.5", "input address",
          dual=True, hexable=True),
        L(ch + " type", OneOf((1, 2, 3, 6, 9, 11, 12)), "RW", "1", S + "6.5.6",
          "channel type"),
        L(ch + " format", Format(), "RW", "0.1", S + "6.5.7", "value format"),
        L(ch + " value", NoValue(), "R", "", S + "6.5.8", "measure now", reader=_read_value,
          stored=False),
        L(ch + " value", OptionalInteger(1, 9), "W", "", S + "6.5.8",
          "measure now and store a row of type t (default 2)", group_writer=_write_values,
          stored=False),
        L(ch + " sample", NoValue(), "R", "", S + "6.5.9", "last scheduled sample",
          reader=_read_sample, stored=False),
        L(ch + " cal mult value", Number(fmt=_own_format("mult"), fmt_doc="cal mult format"),
          "RW", "1", S + "6.5.10.1", "multiplicative calibration"),
        L(ch + " cal mult format", Format(), "RW", "0.0", S + "6.5.10.3.2",
          "format of cal mult value"),
        L(ch + " cal add value", Number(fmt=_own_format("add"), fmt_doc="cal add format"),
          "RW", "0", S + "6.5.10.2", "additive calibration"),
        L(ch + " cal add format", Format(), "RW", "0.0", S + "6.5.10.3.2",
          "format of cal add value"),
        L(ch + " cal2 mult", Number(), "RW", "1", S + "6.5.11",
          "input multiplicative calibration", dual=True),
        L(ch + " cal2 add", Number(), "RW", "0", S + "6.5.11", "input additive calibration",
          dual=True),
        L(ch + " switch output", Integer(0, 7), "RW", "1", S + "6.5.13.1",
          "output switching the sensor (0 = none)", dual=True),
        L(ch + " switch advance", Integer(0, _U16), "RW", "1", S + "6.5.13.2",
          "seconds the switch is on before sampling", dual=True),
        L(ch + " convert {tab} file name", Text(10), "RW", "", S + "6.5.12.1",
          "conversion table name"),
        L(ch + " sampling period", Period(), "RW", "000000", S + "6.5.14.1",
          "sampling period (000000 = stopped)"),
        L(ch + " sampling start", Date(), "RW", "20000101000000", S + "6.5.14.2",
          "sampling start"),
        L(ch + " average samples", Integer(0, _U16), "RW", "0", S + "6.5.15",
          "samples averaged per value (0 = off)"),
        L(ch + " record change",
          Number(fmt=_channel_format, lo=Decimal(0), special=(Decimal(-1),),
                 fmt_doc="channel format"),
          "RW", "0", S + "6.5.16.1", "change that triggers a row (0 always, -1 never)"),
        L(ch + " record samples", Integer(0, _U16), "RW", "0", S + "6.5.16.2",
          "row every n samples (0 = off)"),
        L(ch + " record value", NoValue(), "R", "", S + "6.5.16.3", "last recorded value",
          reader=_read_recorded, stored=False),
        # §6.6 record
        L("record {n} from date", NoValue(), "R", "", S + "6.6.1.1", "rows from a point",
          read_arg=Text(), reader=_read_record_from_date, stored=False),
        L("record {n} from start", NoValue(), "R", "", S + "6.6.1.2", "rows from the oldest",
          reader=_read_record_from_start, stored=False),
        L("record {n} from last {pt} read hold", NoValue(), "R", "", S + "6.6.1.3",
          "rows after a last-read point, point kept", reader=_read_record_from_last(False),
          stored=False),
        L("record {n} from last {pt} read shift", NoValue(), "R", "", S + "6.6.1.4",
          "rows after a last-read point, point moved", reader=_read_record_from_last(True),
          stored=False),
        L("record last {pt} read", Text(), "RW", "", S + "6.6.2", "last-read point"),
        L("record space", NoValue(), "R", "", S + "6.6.3", "total memory",
          reader=_read_record_space, stored=False),
        L("record type", Choice(("CYCLIC", "LINEAR")), "RW", "CYCLIC", S + "6.6.4",
          "cyclic or linear record (only while empty)", writer=_write_record_type),
        L("record status", NoValue(), "R", "", S + "6.6.5", "characters,fill,state",
          reader=_read_record_status, stored=False),
        L("record status clear", NoValue(), "W", "", S + "6.6.5.1", "erase the record",
          writer=_write_record_clear, stored=False),
        # §6.7 output
        L("output {out} device", Integer(0, 8), "RW",
          lambda v, i: "1" if i["out"] == 1 else "0", S + "6.7.1", "device of the output",
          default_doc="1 for output 1, else 0"),
        L("output {out} address", Integer(0, _U16), "RW",
          lambda v, i: "7" if i["out"] == 1 else "0", S + "6.7.2", "address on the device",
          default_doc="7 for output 1, else 0"),
        L("output {out} value", OutputValue(), "RW", "NO", S + "6.7.3",
          "0, 1, or NO for automatic switching"),
        # §6.8 command
        L("command max number", NoValue(), "R", "", S + "6.8", "number of named commands",
          reader=_limit("commands"), stored=False),
        L("command {cmd} name", Text(20), "RW", "", S + "6.8.2", "command name"),
        L("command {cmd} value", Text(100), "RW", "", S + "6.8.3", "command line to run"),
        L("command channel switch hold", Period(), "RW", "000005", S + "6.9",
          "switch hold after an on-demand read"),
        # §6.10 address
        L("address max number", NoValue(), "R", "", S + "6.10", "number of addresses",
          reader=_limit("addresses"), stored=False),
        L("address {adr} type",
          Choice(("SMS", "EMAIL", "RINGVOICE", "RINGDATA"),
                 with_arg={"RINGVOICE": Integer(1, _messages),
                           "RINGDATA": Integer(1, _messages)}),
          "RW", "SMS", S + "6.10.2", "address type"),
        L("address {adr} value", Text(), "RW", "", S + "6.10.3", "phone number or e-mail"),
        # §6.11 com
        L("com speed", OneOf(BAUD_RATES), "RW", "9600", S + "6.11.2", "baud rate"),
        L("com max speed", OneOf(BAUD_RATES), "RW", "230400", S + "6.11.3",
          "recommended maximum baud rate"),
        L("com transmitter mode", Choice(("SAVING", "FOLLOW", "ON")), "RW", "SAVING",
          S + "6.11.4", "RS-232 transmitter mode"),
        L("com device", Choice(("LOCAL", "WAVECOM40", "WAVECOM41", "WAVECOM42")), "RW",
          "LOCAL", S + "6.11.5", "communication device"),
        L("com device mode", Choice(("SAVING", "GSM", "GPRS")), "RW", "", S + "6.11.5.3",
          "idle mode of the wavecom modem", aliases=("com mode",), reader=_read_com_mode,
          writer=_write_com_mode, stored=False,
          default_doc="none: error while com device is LOCAL"),
        L("com network smc", Text(), "RW", "", S + "6.11.6.1", "SMS centre",
          aliases=("com network smsc",)),
        L("com network apn address", Text(), "RW", "", S + "6.11.6.2", "GPRS APN"),
        L("com network smtp address", Text(), "RW", "", S + "6.11.6.3",
          "[user:password@]smtp server"),
        L("com network pop3 address", Text(), "RW", "", S + "6.11.6.4.1",
          "user:password@pop3 server"),
        L("com network pop3 size", Integer(0, 10_000_000), "RW", "10000", S + "6.11.6.4.2",
          "largest command e-mail"),
        L("com network pop3 time", Integer(0, _U16), "RW", "120", S + "6.11.6.4.3",
          "longest e-mail download, seconds"),
        L("com network delay", Integer(0, _U16), "RW", "0", S + "6.11.6.5",
          "seconds to wait after GSM registration"),
        L("com status sim credit code", RestOfLine(), "RW", "", S + "6.11.7",
          "credit query code and answer prefixes"),
        L("com close", NoValue(), "W", "", S + "6.11.8", "release the line for messages",
          writer=_write_com_close, stored=False),
        # §6.12 sms, §6.13 email send
        L("sms command boundary", Text(10), "RW", "##*#", S + "6.12.1",
          "marks a command in an SMS"),
        L("sms email address start", Text(10), "RW", "startemail", S + "6.12.2.1",
          "text before a reply address"),
        L("sms email address end", Text(10), "RW", "endemail", S + "6.12.2.2",
          "text after a reply address"),
        L("email send from", Text(), "RW", "", S + "6.13.1", "sender address"),
        L("email send subject", Text(20), "RW", "", S + "6.13.2", "subject"),
        # §6.14 message
        L("message max number", NoValue(), "R", "", S + "6.14", "number of messages",
          reader=_limit("messages"), stored=False),
        L("message {msg} address",
          IntList(Integer(1, _addresses), lambda lim: lim.addresses_per_message), "RW", "1",
          S + "6.14.2", "address numbers"),
        L("message {msg} command", Integer(1, _commands), "RW", "1", S + "6.14.3",
          "command whose answer is sent"),
        L("message {msg} period", Period(month=True), "RW", "000000", S + "6.14.4",
          "sending period (000000 = off)"),
        L("message {msg} start", Date(), "RW", "20000101000000", S + "6.14.5",
          "start of the period"),
        L("message {msg} of record function", Choice(("YES", "NO")), "RW", "NO",
          S + "6.14.6.1", "send on new record rows"),
        L("message {msg} of channel function", Choice(("NO", "UP", "DOWN")), "RW", "NO",
          S + "6.14.7.1", "send when a value is crossed"),
        L("message {msg} of channel number", Integer(1, _channels), "RW", "1",
          S + "6.14.7.2", "channel watched"),
        L("message {msg} of channel value",
          Number(fmt=_message_channel_format, fmt_doc="watched channel's format"), "RW", "0",
          S + "6.14.7.3", "value watched"),
        L("message {msg} of channel hysteresis",
          Number(fmt=_message_channel_format, lo=Decimal(0),
                 fmt_doc="watched channel's format"),
          "RW", "0", S + "6.14.7.4", "hysteresis"),
        L("message {msg} run", Integer(1, 1), "W", "", S + "6.14.8", "send now",
          unavailable=LATER_MESSAGES, stored=False),
        # §6.15 file
        L("file record size", MemorySize(minimum=256), "RW", str(TOTAL_MEMORY),
          S + "6.15.1", "record area (write first)", writer=_write_record_size),
        L("file list size", MemorySize(), "RW", "0", S + "6.15.2",
          "table list area (write second)", writer=_write_list_size),
        L("file data size", MemorySize(), "RW", "0", S + "6.15.3",
          "table data area (write last)", writer=_write_data_size),
        L("file free size", NoValue(), "R", "", S + "6.15.4", "unused memory",
          reader=_read_free_size, stored=False),
        # §6.16 special
        L("special file record xmodem", NoValue(), "RW", "", S + "6.16.3", "record area by XMODEM",
          reader=_transfer("record"), writer=_transfer_in("record"), stored=False),
        L("special file list xmodem", NoValue(), "RW", "", S + "6.16.1", "table list by XMODEM",
          reader=_transfer("list"), writer=_transfer_in("list"), stored=False),
        L("special file data xmodem", NoValue(), "RW", "", S + "6.16.2", "table data by XMODEM",
          reader=_transfer("data"), writer=_transfer_in("data"), stored=False),
        L("special program xmodem", NoValue(), "W", "", S + "6.16.4",
          "program upgrade by XMODEM (resets the module)", writer=_transfer_in("program"),
          stored=False),
        # §6.17 global
        L("global reset", NoValue(), "W", "", S + "6.17.1",
          "factory values (keeps com speed, device, transmitter mode); ends the line",
          writer=_write_global_reset, ends_line=True, stored=False),
        L("global timing", OneOf((8, 64, 4096)), "RW", "8", S + "6.17.2",
          "input sampling rate for MSP430ADC pulse counting"),
        # §6.18 nothing, §6.19 text
        L("nothing", NoValue(), "RW", "", S + "6.18", "empty command",
          reader=_read_nothing, writer=_write_nothing, stored=False),
        L("text", NoValue(), "R", "", S + "6.19", "echo a string", read_arg=Text(),
          reader=_read_text, stored=False),
        L("text", TextRow(), "W", "", S + "6.19", "store a text row (type 3 unless given)",
          writer=_write_text, stored=False),
    ]  # fmt: skip


LEAVES: list[Leaf] = _leaves()

#: Keys kept when ``global reset`` runs (§6.17.1), and the program version, which a reset
#: does not change (it is not a setting).
RESET_KEEPS = ("com speed", "com device", "com transmitter mode", "i program")


# -- the keyword trie ------------------------------------------------------------------------


@dataclass
class Node:
    """A node of the keyword tree."""

    words: dict[str, Node] = field(default_factory=dict)
    index: tuple[IndexSpec, Node] | None = None
    leaves: dict[str, Leaf] = field(default_factory=dict)  # "R" / "W"


def _build() -> Node:
    root = Node()
    for leaf in LEAVES:
        for pattern in (leaf.pattern, *leaf.aliases):
            node = root
            for word in pattern.split():
                if word.startswith("{"):
                    spec = INDEX_SPECS[word[1:-1]]
                    if node.index is None:
                        node.index = (spec, Node())
                    node = node.index[1]
                else:
                    node = node.words.setdefault(word, Node())
            for access in leaf.access:
                if access in node.leaves:
                    raise RuntimeError(f"duplicate leaf {pattern} {access}")
                node.leaves[access] = leaf
    return root


ROOT: Node = _build()


@dataclass(frozen=True)
class KeyInfo:
    leaf: Leaf
    indices: Indices


def _expand(leaf: Leaf, limits: Limits) -> list[Indices]:
    names = [w[1:-1] for w in leaf.words if w.startswith("{")]
    combos: list[Indices] = [{}]
    for name in names:
        spec = INDEX_SPECS[name]
        combos = [{**c, name: i} for c in combos for i in range(spec.lo, spec.hi(limits) + 1)]
    return combos


def storage_keys(version: Version) -> dict[str, KeyInfo]:
    """Every stored key of a module of ``version``, with its leaf and indices."""
    from sondalog.ala1.model import LIMITS

    limits = LIMITS[version]
    keys: dict[str, KeyInfo] = {}
    for leaf in LEAVES:
        if not leaf.stored:
            continue
        for indices in _expand(leaf, limits):
            info = KeyInfo(leaf, indices)
            keys[leaf.key(indices)] = info
            if leaf.dual:
                keys[leaf.key(indices, 2)] = info
    return keys


__all__ = [
    "INDEX_SPECS",
    "LEAVES",
    "RESET_KEEPS",
    "ROOT",
    "IndexSpec",
    "KeyInfo",
    "Leaf",
    "Node",
    "ParseError",
    "fixed",
    "storage_keys",
]
