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

    [[bus.modules]]    # a real sensor instead of a signal (backends/sensor_sources.py)
    id = "T2"
    kind = "temp"
    source = "w1:28-000008d5e4fd"   # or "iio:DEVICE:CHANNEL" with scale and offset

The signal tables are those of :mod:`sondalog.backends.sim.signals`; the sources are the
kinds registered in :mod:`sondalog.backends.sensor_sources`. Loading makes a typed plan
(:class:`BusSite`) once: its signals are bound to the start time when the bus is built
(:meth:`~sondalog.backends.sim.signals.SignalPlan.build`). A wrong file is rejected with a
:class:`ConfigError` naming the file, the line and the field; unknown keys are refused with a
"did you mean".
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

from sondalog.backends.sensor_sources import SourcePlan, read_source, source_keys
from sondalog.backends.sim.signals import SignalPlan, plan_signal
from sondalog.config import ConfigError, Table, load, of
from sondalog.hctmps1.module import DEFAULT_CYCLE
from sondalog.hctmps1.variants import Kind, variant_for
from sondalog.protocol.hctmps1_frames import is_valid_id

__all__ = ["BusSite", "ConfigError", "ModuleSite", "default_bus_site", "load_bus_site"]

_BUS_KEYS = {"baud", "noise", "seed", "modules", "serve"}  # serve: app/site.py
_MODULE_KEYS = {"id", "kind", "cycle", "signal", "source", "scale", "offset"}
_ID = "1 to 8 of A-Z a-z 0-9 _ -"
_NOISE = "a bit error rate in [0, 1)"


@dataclass(frozen=True, slots=True)
class ModuleSite:
    """One module on the bus: a simulated ``signal``, or a real sensor (``source``)."""

    module_id: str
    kind: Kind
    signal: SignalPlan | None
    cycle: float = DEFAULT_CYCLE
    source: SourcePlan | None = None


@dataclass(frozen=True, slots=True)
class BusSite:
    """Everything the bus reads from a site file: the plan its start consumes."""

    modules: tuple[ModuleSite, ...]
    baud: int | None = None
    noise: float = 0.0
    seed: int | None = None
    path: Path | None = None


def default_bus_site() -> BusSite:
    """The bus without a site file: ``T1`` (temperature) and ``H1`` (humidity), hctmps1.md §1."""
    day = {"period": 86400.0, "origin": 0.0}
    temp = plan_signal(of({"model": "sine", "mean": 21.0, "amplitude": 3.0, **day}))
    hum = plan_signal(of({"model": "sine", "mean": 50.0, "amplitude": 10.0, **day}))
    return BusSite(modules=(ModuleSite("T1", Kind.TEMP, temp), ModuleSite("H1", Kind.HUM, hum)))


def load_bus_site(path: Path) -> BusSite:
    """Read and check the bus part of the site file at ``path``."""
    return read_bus_site(load(path))


def read_bus_site(site: Table) -> BusSite:
    """Check the ``[bus]`` table of the site file whose root table is ``site``."""
    if not site.is_table("bus"):
        close = difflib.get_close_matches("bus", [k for k in site if site.is_table(k)], n=1)
        hint = f" (is [{close[0]}] meant to be it?)" if close else ""
        raise site.fail("bus", f"the site file needs a [bus] table{hint}")
    bus = site.table("bus").keys(_BUS_KEYS)
    baud = bus.opt_integer("baud", lo=1, what="a positive integer")
    noise = bus.number("noise", 0.0, lo=0.0, what=_NOISE)
    if noise >= 1:
        raise bus.fail("noise", f"must be {_NOISE}, not {bus.raw('noise')!r}")
    seed = bus.opt_integer("seed")
    tables = bus.tables("modules")
    if not tables:
        raise bus.fail("modules", "at least one [[bus.modules]] entry is needed")
    modules: list[ModuleSite] = []
    for table in tables:
        module = _module(table)
        if any(m.module_id == module.module_id for m in modules):
            raise table.fail("id", f"duplicate module ID {module.module_id!r}")
        modules.append(module)
    return BusSite(tuple(modules), baud, noise, seed, site.file)


def _module(t: Table) -> ModuleSite:
    """One ``[[bus.modules]]`` table: its ID, kind, cycle and signal or source."""
    t.keys(_MODULE_KEYS | source_keys(t))
    module_id = t.text("id", what=_ID)
    if not is_valid_id(module_id):
        raise t.fail("id", f"must be {_ID}, not {module_id!r}")
    kind = Kind(t.text("kind", choices=[k.value for k in Kind]))
    cycle = t.number(
        "cycle",
        DEFAULT_CYCLE,
        above=variant_for(kind).conversion_time,
        what="seconds, longer than the conversion",
    )
    if "source" in t:
        if "signal" in t:
            raise t.fail("signal", "a module has a signal or a source, not both")
        return ModuleSite(module_id, kind, None, cycle, read_source(t, kind))
    for key in ("scale", "offset"):
        if key in t:
            raise t.fail(key, "only a module with a source has a scale and offset")
    if not t.is_table("signal"):
        raise t.fail("signal", "a signal table (or a source) is required")
    return ModuleSite(module_id, kind, plan_signal(t.table("signal")), cycle)
