"""The bus part of a site file: which HCTMPS1 modules sit on the bus and what they measure.

A site file is TOML. The bus reads its ``[bus]`` table and ignores other top-level tables
(the ALA1 logger's simulation keeps its own there)::

    [bus]
    baud = 9600        # optional; --baud overrides it
    noise = 0.0        # optional bit error rate injected on the line
    seed = 1           # optional seed of the modules' random reply delays

    [[bus.modules]]
    id = "T1"          # factory ID (hctmps1.md §1)
    kind = "temp"      # temp (DS18B20) or hum (SHT11)
    cycle = 10.0       # optional measurement cycle, seconds
    signal = { model = "sine", mean = 21.0, amplitude = 2.0, period = 86400 }

    [[bus.modules]]    # a real sensor instead of a signal (backends/linux/sources.py)
    id = "T2"
    kind = "temp"
    source = "w1:28-000008d5e4fd"   # or "iio:DEVICE:CHANNEL" with scale and offset

The signal tables are those of :mod:`sondalog.backends.sim.signals`. A wrong file is rejected with a
:class:`ConfigError` naming the file, the field and, where it can be found, the line.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from sondalog.backends.linux.sources import SourceError, SourceSpec, parse_source
from sondalog.backends.sim.signals import Signal, SignalError, build_signal
from sondalog.config import ConfigError, locate, read_site_file
from sondalog.hctmps1.module import DEFAULT_CYCLE
from sondalog.hctmps1.variants import Kind, variant_for
from sondalog.protocol.hctmps1_frames import is_valid_id

_BUS_KEYS = {"baud", "noise", "seed", "modules", "serve"}  # serve: app/site.py
_MODULE_KEYS = {"id", "kind", "cycle", "signal", "source", "scale", "offset"}


@dataclass(frozen=True, slots=True)
class ModuleSite:
    """One module on the bus: a simulated ``signal``, or a real sensor (``source``)."""

    module_id: str
    kind: Kind
    signal: Signal | None
    cycle: float = DEFAULT_CYCLE
    source: SourceSpec | None = None


@dataclass(frozen=True, slots=True)
class BusSite:
    """Everything the bus reads from a site file."""

    modules: tuple[ModuleSite, ...]
    baud: int | None = None
    noise: float = 0.0
    seed: int | None = None
    path: Path | None = None


def default_bus_site(start: float) -> BusSite:
    """The bus without a site file: ``T1`` (temperature) and ``H1`` (humidity), hctmps1.md §1."""
    day = {"period": 86400.0, "origin": 0.0}
    return BusSite(
        modules=(
            ModuleSite(
                "T1",
                Kind.TEMP,
                build_signal({"model": "sine", "mean": 21.0, "amplitude": 3.0, **day}, start),
            ),
            ModuleSite(
                "H1",
                Kind.HUM,
                build_signal({"model": "sine", "mean": 50.0, "amplitude": 10.0, **day}, start),
            ),
        )
    )


def load_bus_site(path: Path, start: float) -> BusSite:
    """Read and check the bus part of the site file at ``path``."""
    data, text = read_site_file(path)
    return parse_bus_site(data, start, path, text)


def parse_bus_site(
    data: Mapping[str, object],
    start: float,
    path: Path | None = None,
    text: str | None = None,
) -> BusSite:
    """Check the ``[bus]`` table of an already parsed site file."""

    def fail(field: str, message: str) -> ConfigError:
        return ConfigError(path, field, message, locate(text, field))

    bus = data.get("bus")
    if not isinstance(bus, Mapping):
        raise fail("bus", "the site file needs a [bus] table")
    for key in bus:
        if key not in _BUS_KEYS:
            raise fail(f"bus.{key}", f"unknown key (known: {', '.join(sorted(_BUS_KEYS))})")
    baud = bus.get("baud")
    if baud is not None and (isinstance(baud, bool) or not isinstance(baud, int) or baud <= 0):
        raise fail("bus.baud", f"must be a positive integer, not {baud!r}")
    noise = bus.get("noise", 0.0)
    if isinstance(noise, bool) or not isinstance(noise, int | float) or not 0 <= noise < 1:
        raise fail("bus.noise", f"must be a bit error rate in [0, 1), not {noise!r}")
    seed = bus.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise fail("bus.seed", f"must be an integer, not {seed!r}")
    raw_modules = bus.get("modules")
    if not isinstance(raw_modules, list) or not raw_modules:
        raise fail("bus.modules", "at least one [[bus.modules]] entry is needed")
    base_dir = path.parent if path is not None else None
    modules: list[ModuleSite] = []
    for i, raw in enumerate(raw_modules):
        where = f"bus.modules[{i}]"
        if not isinstance(raw, Mapping):
            raise fail(where, "must be a table")
        for key in raw:
            if key not in _MODULE_KEYS:
                known = ", ".join(sorted(_MODULE_KEYS))
                raise fail(f"{where}.{key}", f"unknown key (known: {known})")
        module_id = raw.get("id")
        if not isinstance(module_id, str) or not is_valid_id(module_id):
            raise fail(f"{where}.id", f"must be 1 to 8 of A-Z a-z 0-9 _ -, not {module_id!r}")
        if any(m.module_id == module_id for m in modules):
            raise fail(f"{where}.id", f"duplicate module ID {module_id!r}")
        kind_text = raw.get("kind")
        if kind_text not in ("temp", "hum"):
            raise fail(f"{where}.kind", f"must be 'temp' or 'hum', not {kind_text!r}")
        kind = Kind(kind_text)
        cycle = raw.get("cycle", DEFAULT_CYCLE)
        if (
            isinstance(cycle, bool)
            or not isinstance(cycle, int | float)
            or cycle <= variant_for(kind).conversion_time
        ):
            raise fail(
                f"{where}.cycle", f"must be seconds, longer than the conversion, not {cycle!r}"
            )
        if "source" in raw:
            source = _source(raw, kind, where, fail)
            modules.append(ModuleSite(module_id, kind, None, float(cycle), source))
            continue
        for key in ("scale", "offset"):
            if key in raw:
                raise fail(f"{where}.{key}", "only a module with a source has a scale and offset")
        signal_table = raw.get("signal")
        if not isinstance(signal_table, Mapping):
            raise fail(f"{where}.signal", "a signal table (or a source) is required")
        try:
            signal = build_signal(signal_table, start, base_dir)
        except SignalError as exc:
            raise fail(f"{where}.signal.{exc.field}", exc.message) from None
        modules.append(ModuleSite(module_id, kind, signal, float(cycle)))
    return BusSite(tuple(modules), baud, float(noise), seed, path)


def _source(
    raw: Mapping[str, object], kind: Kind, where: str, fail: Callable[[str, str], ConfigError]
) -> SourceSpec:
    """A module's real sensor: ``source`` with its ``scale`` and ``offset``."""
    if "signal" in raw:
        raise fail(f"{where}.signal", "a module has a signal or a source, not both")
    numbers = []
    for key, default in (("scale", 1.0), ("offset", 0.0)):
        value = raw.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise fail(f"{where}.{key}", f"must be a number, not {value!r}")
        numbers.append(float(value))
    text = raw["source"]
    if not isinstance(text, str):
        raise fail(f"{where}.source", "must be a string (w1:28-... or iio:DEVICE:CHANNEL)")
    try:
        spec = parse_source(text, numbers[0], numbers[1])
    except SourceError as exc:
        raise fail(f"{where}.source", str(exc)) from None
    if spec.bus == "w1" and kind is not Kind.TEMP:
        raise fail(f"{where}.source", "a DS18B20 measures temperature: kind must be 'temp'")
    return spec
