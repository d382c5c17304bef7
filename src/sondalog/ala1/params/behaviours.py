"""What parameters do beyond storing a value: computed reads and writes with effects (§6)."""

from __future__ import annotations

from collections.abc import Callable

from sondalog.ala1.model import (
    TOTAL_MEMORY,
    CommandError,
    View,
)
from sondalog.ala1.params.leaf import Default, Reader, Writer
from sondalog.ala1.record import row_key
from sondalog.ala1.tokens import NumberFormat, format_stamp
from sondalog.ala1.values import (
    Indices,
)

# -- behaviours ------------------------------------------------------------------------------


def channel_format(view: View, indices: Indices) -> NumberFormat:
    return NumberFormat.parse(view.get(f"channel {indices['ch']} format"))


def own_format(which: str) -> Callable[[View, Indices], NumberFormat]:
    def fmt(view: View, indices: Indices) -> NumberFormat:
        return NumberFormat.parse(view.get(f"channel {indices['ch']} cal {which} format"))

    return fmt


def message_channel_format(view: View, indices: Indices) -> NumberFormat:
    channel = int(view.get(f"message {indices['msg']} of channel number"))
    return NumberFormat.parse(view.get(f"channel {channel} format"))


#: Factory device calibration per device type (§6.4.4; sondalog decision for MSP430ADC:
#: the internal 2.5 V reference of the MSP430F149 and no offset).
FACTORY_CAL: dict[str, tuple[str, str]] = {
    "MSP430ADC": ("2.5", "0"),
    "MSP430TA": ("1", "0"),
    "DS18B20": ("3276.8", "0"),
}


def device_cal_default(which: int) -> Default:
    def default(view: View, indices: Indices) -> str:
        return FACTORY_CAL[view.get(f"device {indices['dev']} type")][which]

    return default


def write_device_type(view: View, indices: Indices, values: list[str]) -> None:
    """§6.4.4.3: choosing a device type restores its factory calibration."""
    dev = indices["dev"]
    view.set(f"device {dev} type", values[0])
    mult, add = FACTORY_CAL[values[0]]
    view.set(f"device {dev} cal mult", mult)
    view.set(f"device {dev} cal add", add)


def read_date(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [format_stamp(view.now())]


def write_date(view: View, indices: Indices, values: list[str]) -> None:
    from sondalog.ala1.tokens import parse_stamp

    view.set_clock(parse_stamp(values[0]))


def identity(attr: str) -> Reader:
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


def serial_number(view: View, indices: Indices) -> str:
    return view.identity.serial_number


def program(view: View, indices: Indices) -> str:
    return view.identity.program


def limit(attr: str) -> Reader:
    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        return [str(getattr(view.identity.limits, attr))]

    return read


COM_MODES = {"WAVECOM40": "SAVING", "WAVECOM41": "GSM", "WAVECOM42": "GPRS"}


def read_com_mode(view: View, indices: Indices, arg: str | None) -> list[str]:
    device = view.get("com device")
    if device == "LOCAL":
        raise CommandError("com mode needs a wavecom device (§6.11.5.3)")
    return [COM_MODES[device]]


def write_com_mode(view: View, indices: Indices, values: list[str]) -> None:
    if view.get("com device") == "LOCAL":
        raise CommandError("com mode needs a wavecom device (§6.11.5.3)")
    device = {mode: dev for dev, mode in COM_MODES.items()}[values[0]]
    view.set("com device", device)


def sizes(view: View) -> tuple[int, int, int]:
    return (
        int(view.get("file record size")),
        int(view.get("file list size")),
        int(view.get("file data size")),
    )


def write_record_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.1: written first; zeroes the list and data areas and clears the record."""
    view.set("file record size", values[0])
    view.set("file list size", "0")
    view.set("file data size", "0")
    view.clear_record()


def write_list_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.2: written second; zeroes the data area."""
    record, _, _ = sizes(view)
    if record + int(values[0]) > TOTAL_MEMORY:
        raise CommandError("the areas exceed the memory")
    view.set("file list size", values[0])
    view.set("file data size", "0")


def write_data_size(view: View, indices: Indices, values: list[str]) -> None:
    """§6.15.3: written last."""
    record, listing, _ = sizes(view)
    if record + listing + int(values[0]) > TOTAL_MEMORY:
        raise CommandError("the areas exceed the memory")
    view.set("file data size", values[0])


def read_free_size(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [str(TOTAL_MEMORY - sum(sizes(view)))]


def read_record_space(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [str(TOTAL_MEMORY)]


def read_record_status(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.record.status()]


def write_record_type(view: View, indices: Indices, values: list[str]) -> None:
    """§6.6.4: the type can change only while the record is empty."""
    if len(view.record) and values[0] != view.get("record type"):
        raise CommandError("the record type changes only while the record is empty")
    view.set("record type", values[0])


def start_of(view: View, point: str) -> int:
    """§6.6.1: with the ``.c`` counter, rows after that row; without, from the oldest row
    at or after the point; an empty point is before the oldest row."""
    if not point:
        return 0
    if "." in point:
        return view.record.position_after(point)
    return view.record.position_at_or_after(point)


def read_record_from_date(view: View, indices: Indices, arg: str | None) -> list[str]:
    return view.record.rows(start_of(view, arg or ""), indices["n"])


def read_record_from_start(view: View, indices: Indices, arg: str | None) -> list[str]:
    return view.record.rows(0, indices["n"])


def read_record_from_last(shift: bool) -> Reader:
    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        key = f"record last {indices['pt']} read"
        rows = view.record.rows(start_of(view, view.get(key)), indices["n"])
        if shift and rows:
            view.move_point(key, row_key(rows[-1]))
        return rows

    return read


def read_value(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.measure(indices["ch"])]


def read_values(view: View, targets: list[Indices], arg: str | None) -> list[str]:
    """§6.5.8: several channels measured now, one line."""
    return [",".join(view.measure_many([t["ch"] for t in targets]))]


def write_values(view: View, targets: list[Indices], values: list[str]) -> None:
    """§6.5.8: measure the channels now and store them as one row of type t (default 2)."""
    count = int(view.get("channel max number"))
    channels = [t["ch"] for t in targets]
    fields = [""] * max(count, *channels)
    for ch, value in zip(channels, view.measure_many(channels), strict=True):
        fields[ch - 1] = value
    view.append_row(int(values[0]) if values else 2, ",".join(fields[:count]))


def read_sample(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.channel_state(indices["ch"])[0]]


def read_recorded(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [view.channel_state(indices["ch"])[1]]


def write_text(view: View, indices: Indices, values: list[str]) -> None:
    """§6.19: the string becomes a row ``stamp,t,s`` (type 3 unless given)."""
    row_type, _, text = values[0].partition(",")
    view.append_row(int(row_type), text)


def write_record_clear(view: View, indices: Indices, values: list[str]) -> None:
    view.clear_record()
    for point in range(1, 5):
        view.set(f"record last {point} read", "")


def write_global_reset(view: View, indices: Indices, values: list[str]) -> None:
    """§6.17.1: factory values except the three communication parameters; record erased."""
    view.reset(keep=("com speed", "com device", "com transmitter mode"))
    view.clear_record()


def transfer(area: str) -> Reader:
    """§6.16: the module sends the area by XMODEM after the command."""

    def read(view: View, indices: Indices, arg: str | None) -> list[str]:
        view.start_transfer(area, reading=True)
        return []

    return read


def transfer_in(area: str) -> Writer:
    """§6.16: the module receives the area by XMODEM after the command."""

    def write(view: View, indices: Indices, values: list[str]) -> None:
        view.start_transfer(area, reading=False)

    return write


def read_nothing(view: View, indices: Indices, arg: str | None) -> list[str]:
    return []


def write_nothing(view: View, indices: Indices, values: list[str]) -> None:
    return None


def read_text(view: View, indices: Indices, arg: str | None) -> list[str]:
    return [arg or ""]


def write_com_close(view: View, indices: Indices, values: list[str]) -> None:
    """§6.11.8: release the line so that messages may be sent (§6.14.9.2)."""
    view.release_line()


def write_message_run(view: View, indices: Indices, values: list[str]) -> None:
    """§6.14.8: ``run 1`` sends the message even though no condition was met."""
    view.run_message(indices["msg"])
