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

The table is read through :mod:`sondalog.config` into a typed plan (:class:`BoardConfig`):
mistakes are :class:`~sondalog.config.ConfigError` naming file, line and field, unknown keys
and tables are refused with a "did you mean". A separate board file holds ``[board]`` only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from sondalog.ala1.hardware import ANALOG_ADDRESSES, pin_of
from sondalog.backends.linux.gpio import BiasKind, EdgeKind
from sondalog.backends.linux.rs485 import MODES, Mode, Rs485Error, check_delays
from sondalog.config import ConfigError, Source, Table, load, of

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
_EDGES = ("falling", "rising", "both")
_BIASES = ("as-is", "pull-up", "pull-down", "disabled")


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
        return Source(self.path, self.text).fail(where, message)


def load_board(site: Path) -> BoardConfig | None:
    """The board of the site file ``site``: its ``[board]`` table, or the file its
    ``board = "FILE"`` names; None when the site file has neither."""
    return read_board_of_site(load(site))


def read_board_of_site(site: Table) -> BoardConfig | None:
    """The board of the site file whose root table is ``site`` (None without one)."""
    if "board" not in site:
        return None
    if not site.is_text("board"):
        return read_board(site)
    path = site.path("board")
    try:
        root = load(path)
    except ConfigError as exc:
        if exc.field != "file" or exc.path != path:
            raise
        raise site.fail("board", f"{path}: {exc.message}") from None
    if not root.is_table("board"):
        raise root.fail("board", "the board file needs a [board] table")
    return read_board(root.keys({"board"}))


def parse_board(
    data: Mapping[str, object], path: Path | None = None, text: str | None = None
) -> BoardConfig:
    """Check the ``[board]`` table of a parsed TOML document."""
    return read_board(of(data, path, text))


def read_board(root: Table) -> BoardConfig:
    """Check the ``[board]`` table of the file whose root table is ``root``."""
    if not root.is_table("board"):
        raise root.fail("board", "must be a table ([board])")
    board = root.table("board").keys(_KEYS["board"])
    backend = board.text("backend", "linux")
    if backend != "linux":
        raise board.fail("backend", f"this board file is for 'linux', not {backend!r}")
    ds18b20, analog = _ds18b20(board), _analog(board)
    supply = board.opt_table("supply")
    supply_wiring = _iio(supply.keys(_KEYS["supply"]), None) if supply is not None else None
    pulses, outputs = _pulses(board), _outputs(board)
    _check_lines([*pulses, *outputs], board)
    return BoardConfig(
        ds18b20=ds18b20,
        analog=analog,
        supply=supply_wiring,
        pulses=pulses,
        outputs=outputs,
        rs485=_rs485(board),
        serial=_serial(board),
        external_reference=board.number("external_reference", 2.5, lo=0.1, hi=5.0),
        hold=board.number("hold", 60.0, lo=1.0, hi=86400.0),
        refresh=board.number("refresh", 10.0, lo=1.0, hi=3600.0),
        settle=board.number("settle", 0.5, lo=0.0, hi=60.0),
        path=root.file,
        text=root.source.text,
    )


def _entries(board: Table, key: str) -> list[Table]:
    """The tables of ``[[board.KEY]]``, each holding only the keys of its kind."""
    return [t.keys(_KEYS[key]) for t in board.tables(key)]


def _name(t: Table, key: str) -> str:
    """A required non-blank string (a device, chip or master name)."""
    return t.text(key, pattern=r"(?s).*\S.*", what="a non-empty string")


def _power(t: Table) -> int | None:
    """The output (1..7) powering the sensor, if any."""
    return t.opt_integer("power", lo=1, hi=7)


def _line(t: Table) -> int | str:
    """A GPIO line: its name, or its offset 0..1023."""
    return _name(t, "line") if t.is_text("line") else t.integer("line", lo=0, hi=1023)


def _ds18b20(board: Table) -> tuple[W1Wiring, ...]:
    wires: list[W1Wiring] = []
    for t in _entries(board, "ds18b20"):
        pin = t.integer("pin", lo=0, hi=7)
        if any(w.pin == pin for w in wires):
            raise t.fail("pin", f"P6 bit {pin} is already wired")
        wires.append(W1Wiring(pin, _name(t, "master"), _power(t), t.field()))
    return tuple(wires)


def _iio(t: Table, address: int | None) -> IioWiring:
    gain = t.number("gain", 1.0, lo=1e-6, hi=1e6)
    channel = t.integer("channel", lo=0, hi=255)
    return IioWiring(address, _name(t, "iio"), channel, gain, _power(t), t.field())


def _analog(board: Table) -> tuple[IioWiring, ...]:
    allowed = f"an ADC input address ({', '.join(map(str, ANALOG_ADDRESSES))})"
    inputs: list[IioWiring] = []
    for t in _entries(board, "analog"):
        address = t.integer("address", what=allowed)
        if address not in ANALOG_ADDRESSES:
            raise t.fail("address", f"must be {allowed}, not {address!r}")
        if any(a.address is not None and pin_of(a.address) == pin_of(address) for a in inputs):
            raise t.fail("address", "this input is already wired")
        inputs.append(_iio(t, address))
    return tuple(inputs)


def _pulses(board: Table) -> tuple[PulseWiring, ...]:
    pulses: list[PulseWiring] = []
    for t in _entries(board, "pulses"):
        timer = t.flag("timer", False)
        if timer and "address" in t:
            raise t.fail("address", "give timer = true or an address, not both")
        address = 0 if timer else t.integer("address", lo=0, hi=36)
        if any(p.timer == timer and pin_of(p.address) == pin_of(address) for p in pulses):
            raise t.fail(None, "this pulse input is already wired")
        edge = cast(EdgeKind, t.text("edge", _EDGES[0], choices=_EDGES))
        bias = cast(BiasKind, t.text("bias", _BIASES[0], choices=_BIASES))
        debounce = t.number("debounce", 0.0, lo=0.0, hi=1.0)
        chip = _name(t, "chip")
        pulses.append(PulseWiring(timer, address, chip, _line(t), edge, bias, debounce, t.field()))
    return tuple(pulses)


def _outputs(board: Table) -> tuple[OutputWiring, ...]:
    outputs: list[OutputWiring] = []
    for t in _entries(board, "outputs"):
        output = t.integer("output", lo=1, hi=7)
        if any(o.output == output for o in outputs):
            raise t.fail("output", f"output {output} is already wired")
        low = t.flag("active_low", False)
        outputs.append(OutputWiring(output, _name(t, "chip"), _line(t), low, t.field()))
    return tuple(outputs)


def _check_lines(wires: list[PulseWiring | OutputWiring], board: Table) -> None:
    """No GPIO line is wired twice (a pulse input and an output, or two of either)."""
    used: dict[tuple[str, str], str] = {}
    for wired in wires:
        key = (wired.chip, str(wired.line))
        if key in used:
            raise board.source.fail(
                f"{wired.where}.line", f"{wired.chip} line {wired.line} is used by {used[key]}"
            )
        used[key] = wired.where


def _rs485(board: Table) -> Rs485Wiring | None:
    t = board.opt_table("rs485")
    if t is None:
        return None
    t.keys(_KEYS["rs485"])
    baud = t.integer("baud", 9600, lo=300, hi=4_000_000)
    mode = cast(Mode, t.text("mode", MODES[0], choices=MODES))
    before_tx = t.number("delay_before_tx", 0.0, lo=0.0, hi=0.1)
    before_rx = t.number("delay_before_rx", 0.0, lo=0.0, hi=0.1)
    try:
        check_delays(baud, before_tx, before_rx)
    except Rs485Error as exc:
        raise t.fail("delay_before_rx", str(exc)) from None
    return Rs485Wiring(_name(t, "port"), baud, mode, before_tx, before_rx)


def _serial(board: Table) -> tuple[str, ...]:
    t = board.opt_table("serial")
    if t is None:
        return ()
    t.keys(_KEYS["serial"])
    try:
        ports = t.texts("ports")
    except ConfigError:
        ports = [""]
    if not all(ports):
        raise t.fail("ports", "must be a list of device paths")
    return tuple(ports)
