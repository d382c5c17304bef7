"""HCTMPS1 sensor sources registered by name (python-can's interface pattern; DESIGN.md point 4).

A module on the bus measures a simulated ``signal`` or a real sensor, its ``source``::

    [[bus.modules]]
    id = "H1"
    kind = "hum"
    source = "iio:ads1115:1"        # KIND:ADDRESS -- the kind is a registered name
    scale = 31.25                   # physical value = reading * scale + offset
    offset = -23.8

A kind is a :class:`SourceKind`: its config parsing (the address and, if it has any, its own
keys of the module's table -> typed settings, a frozen dataclass) and its factory (settings
and the file-system root -> a :class:`SensorReader`). ``w1`` (a DS18B20) and ``iio`` (an IIO
voltage channel) are built in (:mod:`sondalog.backends.linux.sources`), imported only when a
site file names them. A new kind is one module and one :func:`register` call::

    register("i2c", SourceKind(form="i2c:BUS:ADDRESS", parse=parse_i2c, open=I2cReader))

The site file's bus part (:mod:`sondalog.backends.sim.site_bus`) reads sources through
:func:`read_source` only; the running bus reads them through
:class:`~sondalog.backends.sensor_bank.SensorBank`, which calls :func:`open_source`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

from sondalog.config import ConfigError, Table
from sondalog.hctmps1.variants import Kind

S = TypeVar("S", bound=Hashable)


class SensorReader(Protocol):
    """A real sensor, read in a worker thread: its reading now, ``None`` if it has none."""

    def read(self) -> float | None: ...


@dataclass(frozen=True)
class SourceKind(Generic[S]):
    """One kind of sensor source: how its address is written, parsed and opened.

    ``parse(address, module, kind)`` gets the text after ``NAME:``, the module's table (for
    the kind's own ``keys``) and the module's kind (temp or hum); it returns the typed
    settings or raises ``ValueError`` (reported at the module's ``source``).
    ``open(settings, root)`` makes the reader (``root`` prefixes ``/sys`` and ``/dev``)."""

    form: str  # how a source of this kind is written, for error messages
    parse: Callable[[str, Table, Kind], S]
    open: Callable[[S, Path], SensorReader]
    keys: frozenset[str] = field(default_factory=frozenset)  # its own keys in [[bus.modules]]


@dataclass(frozen=True, slots=True)
class SourcePlan:
    """A module's real sensor, checked: its kind's settings and the module's scale and offset."""

    text: str  # as written in the site file
    kind: str  # the registered name
    settings: Hashable
    scale: float = 1.0
    offset: float = 0.0


#: name -> "module:attribute" of the built-in kinds, imported on first use.
_BUILTIN: dict[str, str] = {
    "w1": "sondalog.backends.linux.sources:W1_SOURCE",
    "iio": "sondalog.backends.linux.sources:IIO_SOURCE",
}
_REGISTERED: dict[str, SourceKind[Any]] = {}


def register(name: str, kind: SourceKind[Any]) -> None:
    """Make ``kind`` the sensor source called ``name`` (``source = "NAME:..."``)."""
    _REGISTERED[name] = kind


def names() -> list[str]:
    """Every source kind that can be named (the built-in ones first)."""
    return list(dict.fromkeys([*_BUILTIN, *sorted(_REGISTERED)]))


def lookup(name: str) -> SourceKind[Any] | None:
    """The kind called ``name``, or ``None`` (also when its module cannot be imported)."""
    if name in _REGISTERED:
        return _REGISTERED[name]
    target = _BUILTIN.get(name)
    if target is None:
        return None
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        return None
    found: SourceKind[Any] = getattr(module, attr)
    _REGISTERED[name] = found
    return found


def _expected(text: str) -> str:
    forms = [kind.form for name in names() if (kind := lookup(name)) is not None]
    return f"{text!r}: expected {' or '.join(forms)}"


def source_keys(module: Table) -> frozenset[str]:
    """The keys the source of ``module`` reads from its table besides ``source``, ``scale``
    and ``offset`` (none when it has no source or an unknown one)."""
    if not module.is_text("source"):
        return frozenset()
    kind = lookup(str(module.raw("source")).partition(":")[0])
    return kind.keys if kind is not None else frozenset()


def read_source(module: Table, kind: Kind) -> SourcePlan:
    """The ``source`` of the module table ``module`` (with ``scale`` and ``offset``)."""
    scale, offset = module.number("scale", 1.0), module.number("offset", 0.0)
    text = module.text("source", what=f"a string ({' or '.join(names())}:...)")
    name, colon, address = text.partition(":")
    source = lookup(name) if colon else None
    if source is None:
        raise module.fail("source", _expected(text))
    try:
        settings = source.parse(address, module, kind)
    except ConfigError:
        raise
    except ValueError as exc:
        raise module.fail("source", f"{text!r}: {exc}") from None
    return SourcePlan(text, name, settings, scale, offset)


def open_source(plan: SourcePlan, root: Path) -> SensorReader:
    """The reader of ``plan``'s sensor (``root`` prefixes ``/sys`` and ``/dev``)."""
    source = lookup(plan.kind)
    if source is None:  # a plan is only made for a kind that was found
        raise LookupError(f"no sensor source kind {plan.kind!r}")
    return source.open(plan.settings, root)
