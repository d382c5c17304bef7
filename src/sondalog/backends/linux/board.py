"""The board file: what the logger's inputs and outputs are wired to on a Linux board.

A ``[board]`` table, in the site file itself or in a file named by ``board = "FILE"`` in the
site file (relative to it)::

    [board]
    backend = "linux"
    external_reference = 2.5        # volts on K2 pin 2, for addresses 32..36 (§6.5.5)
    hold = 60                       # seconds a reading stays valid in the sample-and-hold
    refresh = 10                    # seconds between background reads when no sample is due
    settle = 0.5                    # seconds a sensor needs after its output switched it on

    [[board.ds18b20]]               # a 1-Wire bus = the DS18B20 device on P6 bit `pin`
    pin = 4                         # the logger's `device N address` (§6.4.2)
    master = "w1_bus_master1"
    power = 2                       # optional: the output powering the sensors (§6.7)

    [[board.analog]]                # an MSP430ADC input (§6.5.5) read through IIO
    address = 16
    iio = "ads1115"                 # the device's name, or "iio:device0"
    channel = 0                     # in_voltage0_raw
    gain = 1.0                      # volts at the input = IIO volts * gain (a divider)
    power = 2

    [board.supply]                  # the supply voltage (channel type 1), volts * gain
    iio = "ads1115"
    channel = 3
    gain = 11.0

    [[board.pulses]]                # a pulse input: the timer input P1.0 or an ADC pin
    timer = true                    # or: address = 17
    chip = "gpiochip0"
    line = 17                       # offset, or the line's name ("GPIO17")
    edge = "falling"                # rising | falling | both
    bias = "pull-up"                # as-is | pull-up | pull-down | disabled
    debounce = 0.005                # seconds (kernel debounce)

    [[board.outputs]]               # output 1..7 (§6.7) driving a GPIO line
    output = 2
    chip = "gpiochip0"
    line = 27
    active_low = false

    [board.rs485]                   # the HCTMPS1 bus on a real adapter
    port = "/dev/ttyUSB0"
    baud = 9600
    mode = "auto"                   # kernel | rts | auto
    delay_before_tx = 0.0
    delay_before_rx = 0.0

    [board.serial]                  # the logger's own line(s): real UARTs, 8N1
    ports = ["/dev/ttyAMA0"]

Mistakes are :class:`~sondalog.backends.sim.site_bus.ConfigError` naming file, line and field.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, cast

from sondalog.ala1.hardware import ANALOG_ADDRESSES, pin_of
from sondalog.backends.linux.gpio import BiasKind, EdgeKind
from sondalog.backends.linux.rs485 import MODES, Mode, Rs485Error, check_delays
from sondalog.config import ConfigError, locate, read_site_file

_KEYS = {
    "board": {
        "backend",
        "external_reference",
        "hold",
        "refresh",
        "settle",
        "ds18b20",
        "analog",
        "supply",
        "pulses",
        "outputs",
        "rs485",
        "serial",
    },
    "ds18b20": {"pin", "master", "power"},
    "analog": {"address", "iio", "channel", "gain", "power"},
    "supply": {"iio", "channel", "gain", "power"},
    "pulses": {"timer", "address", "chip", "line", "edge", "bias", "debounce"},
    "outputs": {"output", "chip", "line", "active_low"},
    "rs485": {"port", "baud", "mode", "delay_before_tx", "delay_before_rx"},
    "serial": {"ports"},
}


@dataclass(frozen=True, slots=True)
class W1Wiring:
    pin: int
    master: str
    power: int | None
    where: str


@dataclass(frozen=True, slots=True)
class IioWiring:
    """An analog input (``address``) or the supply (``address`` None) on an IIO channel."""

    address: int | None
    iio: str
    channel: int
    gain: float
    power: int | None
    where: str


@dataclass(frozen=True, slots=True)
class PulseWiring:
    timer: bool
    address: int
    chip: str
    line: int | str
    edge: EdgeKind
    bias: BiasKind
    debounce: float
    where: str


@dataclass(frozen=True, slots=True)
class OutputWiring:
    output: int
    chip: str
    line: int | str
    active_low: bool
    where: str


@dataclass(frozen=True, slots=True)
class Rs485Wiring:
    port: str
    baud: int
    mode: Mode
    delay_before_tx: float
    delay_before_rx: float


@dataclass(frozen=True)
class BoardConfig:
    """Everything the ``[board]`` table says, checked."""

    ds18b20: tuple[W1Wiring, ...] = ()
    analog: tuple[IioWiring, ...] = ()
    supply: IioWiring | None = None
    pulses: tuple[PulseWiring, ...] = ()
    outputs: tuple[OutputWiring, ...] = ()
    rs485: Rs485Wiring | None = None
    serial: tuple[str, ...] = ()
    external_reference: float = 2.5
    hold: float = 60.0
    refresh: float = 10.0
    settle: float = 0.5
    path: Path | None = None
    text: str | None = None

    def error(self, where: str, message: str) -> ConfigError:
        """A problem found later (a missing device) reported at the field that names it."""
        return ConfigError(self.path, where, message, locate(self.text, where))


def load_board(site: Path) -> BoardConfig | None:
    """The board of the site file ``site``: its ``[board]`` table, or the file its
    ``board = "FILE"`` names; None when the site file has neither."""
    data, text = read_site_file(site)
    return board_of_site(data, site, text)


def board_of_site(
    data: Mapping[str, object], site: Path, text: str | None = None
) -> BoardConfig | None:
    """Like :func:`load_board`, for a site file already read."""
    board = data.get("board")
    if board is None:
        return None
    if isinstance(board, str):
        path = site.parent / board
        try:
            data, text = read_site_file(path)
        except ConfigError as exc:
            if exc.field != "file" or exc.path != path:
                raise
            raise ConfigError(
                site, "board", f"{path}: {exc.message}", locate(text, "board")
            ) from None
        if not isinstance(data.get("board"), Mapping):
            raise ConfigError(path, "board", "the board file needs a [board] table", None)
        return parse_board(data, path, text)
    return parse_board(data, site, text)


def parse_board(
    data: Mapping[str, object], path: Path | None = None, text: str | None = None
) -> BoardConfig:
    """Check the ``[board]`` table of a parsed TOML document."""

    def fail(where: str, message: str, at: str | None = None) -> ConfigError:
        return ConfigError(path, where, message, locate(text, at or where))

    board = data.get("board")
    if not isinstance(board, Mapping):
        raise fail("board", "must be a table ([board])")
    _known(board, "board", "board", fail)
    if board.get("backend", "linux") != "linux":
        raise fail("board.backend", f"this board file is for 'linux', not {board['backend']!r}")

    def number(t: Mapping[str, object], key: str, where: str, lo: float, hi: float) -> float:
        value = t.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
            raise fail(f"{where}.{key}", f"must be a number {lo:g}..{hi:g}, not {value!r}")
        return float(value)

    def integer(t: Mapping[str, object], key: str, where: str, lo: int, hi: int) -> int:
        value = t.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise fail(f"{where}.{key}", f"must be an integer {lo}..{hi}, not {value!r}")
        return value

    def text_of(t: Mapping[str, object], key: str, where: str) -> str:
        value = t.get(key)
        if not isinstance(value, str) or not value.strip():
            raise fail(f"{where}.{key}", f"must be a non-empty string, not {value!r}")
        return value

    def choice(t: Mapping[str, object], key: str, where: str, options: tuple[str, ...]) -> str:
        value = t.get(key, options[0])
        if value not in options:
            raise fail(f"{where}.{key}", f"must be one of {', '.join(options)}, not {value!r}")
        assert isinstance(value, str)
        return value

    def power(t: Mapping[str, object], where: str) -> int | None:
        return integer(t, "power", where, 1, 7) if "power" in t else None

    def line(t: Mapping[str, object], where: str) -> int | str:
        value = t.get("line")
        if isinstance(value, str) and value.strip():
            return value
        return integer(t, "line", where, 0, 1023)

    def entries(key: str) -> list[tuple[str, Mapping[str, object]]]:
        raw = board.get(key, [])
        if not isinstance(raw, list):
            raise fail(f"board.{key}", f"must be an array of tables ([[board.{key}]])")
        out = []
        for i, entry in enumerate(raw):
            where = f"board.{key}[{i}]"
            if not isinstance(entry, Mapping):
                raise fail(where, "must be a table")
            _known(entry, key, where, fail)
            out.append((where, entry))
        return out

    def iio(t: Mapping[str, object], where: str, address: int | None) -> IioWiring:
        gain = number(t, "gain", where, 1e-6, 1e6) if "gain" in t else 1.0
        channel = integer(t, "channel", where, 0, 255)
        return IioWiring(address, text_of(t, "iio", where), channel, gain, power(t, where), where)

    w1: list[W1Wiring] = []
    for where, entry in entries("ds18b20"):
        pin = integer(entry, "pin", where, 0, 7)
        if any(w.pin == pin for w in w1):
            raise fail(f"{where}.pin", f"P6 bit {pin} is already wired")
        w1.append(W1Wiring(pin, text_of(entry, "master", where), power(entry, where), where))

    analog: list[IioWiring] = []
    for where, entry in entries("analog"):
        address = entry.get("address")
        if isinstance(address, bool) or address not in ANALOG_ADDRESSES:
            allowed = ", ".join(map(str, ANALOG_ADDRESSES))
            raise fail(f"{where}.address", f"must be an ADC input address ({allowed})")
        assert isinstance(address, int)
        if any(a.address is not None and pin_of(a.address) == pin_of(address) for a in analog):
            raise fail(f"{where}.address", "this input is already wired")
        analog.append(iio(entry, where, address))

    supply = None
    if "supply" in board:
        raw = board["supply"]
        if not isinstance(raw, Mapping):
            raise fail("board.supply", "must be a table ([board.supply])")
        _known(raw, "supply", "board.supply", fail)
        supply = iio(raw, "board.supply", None)

    pulses: list[PulseWiring] = []
    for where, entry in entries("pulses"):
        timer = entry.get("timer", False)
        if not isinstance(timer, bool):
            raise fail(f"{where}.timer", "must be true or false")
        if timer and "address" in entry:
            raise fail(f"{where}.address", "give timer = true or an address, not both")
        address = 0 if timer else integer(entry, "address", where, 0, 36)
        if any(p.timer == timer and pin_of(p.address) == pin_of(address) for p in pulses):
            raise fail(where, "this pulse input is already wired")
        edge = cast(EdgeKind, choice(entry, "edge", where, ("falling", "rising", "both")))
        bias = cast(
            BiasKind, choice(entry, "bias", where, ("as-is", "pull-up", "pull-down", "disabled"))
        )
        debounce = number(entry, "debounce", where, 0.0, 1.0) if "debounce" in entry else 0.0
        chip = text_of(entry, "chip", where)
        pulses.append(
            PulseWiring(timer, address, chip, line(entry, where), edge, bias, debounce, where)
        )

    outputs: list[OutputWiring] = []
    for where, entry in entries("outputs"):
        output = integer(entry, "output", where, 1, 7)
        if any(o.output == output for o in outputs):
            raise fail(f"{where}.output", f"output {output} is already wired")
        low = entry.get("active_low", False)
        if not isinstance(low, bool):
            raise fail(f"{where}.active_low", "must be true or false")
        outputs.append(
            OutputWiring(output, text_of(entry, "chip", where), line(entry, where), low, where)
        )
    used: dict[tuple[str, str], str] = {}
    wires: list[PulseWiring | OutputWiring] = [*pulses, *outputs]
    for wired in wires:
        key = (wired.chip, str(wired.line))
        if key in used:
            raise fail(
                f"{wired.where}.line", f"{wired.chip} line {wired.line} is used by {used[key]}"
            )
        used[key] = wired.where

    rs485 = None
    if "rs485" in board:
        raw = board["rs485"]
        if not isinstance(raw, Mapping):
            raise fail("board.rs485", "must be a table ([board.rs485])")
        _known(raw, "rs485", "board.rs485", fail)
        baud = integer(raw, "baud", "board.rs485", 300, 4_000_000) if "baud" in raw else 9600
        mode = cast(Mode, choice(raw, "mode", "board.rs485", MODES))
        delays = [
            number(raw, k, "board.rs485", 0.0, 0.1) if k in raw else 0.0
            for k in ("delay_before_tx", "delay_before_rx")
        ]
        try:
            check_delays(baud, delays[0], delays[1])
        except Rs485Error as exc:
            raise fail("board.rs485.delay_before_rx", str(exc)) from None
        port = text_of(raw, "port", "board.rs485")
        rs485 = Rs485Wiring(port, baud, mode, delays[0], delays[1])

    serial: tuple[str, ...] = ()
    if "serial" in board:
        raw = board["serial"]
        if not isinstance(raw, Mapping):
            raise fail("board.serial", "must be a table ([board.serial])")
        _known(raw, "serial", "board.serial", fail)
        ports = raw.get("ports")
        if not isinstance(ports, list) or not all(isinstance(p, str) and p for p in ports):
            raise fail("board.serial.ports", "must be a list of device paths")
        serial = tuple(ports)

    return BoardConfig(
        ds18b20=tuple(w1),
        analog=tuple(analog),
        supply=supply,
        pulses=tuple(pulses),
        outputs=tuple(outputs),
        rs485=rs485,
        serial=serial,
        external_reference=(
            number(board, "external_reference", "board", 0.1, 5.0)
            if "external_reference" in board
            else 2.5
        ),
        hold=number(board, "hold", "board", 1.0, 86400.0) if "hold" in board else 60.0,
        refresh=number(board, "refresh", "board", 1.0, 3600.0) if "refresh" in board else 10.0,
        settle=number(board, "settle", "board", 0.0, 60.0) if "settle" in board else 0.5,
        path=path,
        text=text,
    )


class _Fail(Protocol):
    def __call__(self, where: str, message: str, at: str | None = None) -> ConfigError: ...


def _known(table: Mapping[str, object], kind: str, where: str, fail: _Fail) -> None:
    """Unknown keys are refused at their own line: an array of tables (``[[board.dht22]]``)
    at its first header, not at the table holding it."""
    keys = _KEYS[kind]
    for key, value in table.items():
        if key not in keys:
            field = f"{where}.{key}"
            array = isinstance(value, list) and value and isinstance(value[0], Mapping)
            raise fail(
                field,
                f"unknown key (known: {', '.join(sorted(keys))})",
                f"{field}[0]" if array else None,
            )
