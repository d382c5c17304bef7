"""Sinks by name: a collector sink is one module and one :func:`register_sink` call.

A registration carries all the collector needs to know about the sink:

- its TOML table name (``[postgres]``, ``[mqtt]``, ...): the configuration file accepts a
  top-level table of every registered name (:mod:`sondalog.collect.config`), no edit there;
- its config parsing, ``parse(table, report) -> config``: checks the table when the file is
  loaded (``collect --check`` and a start alike) and returns a typed configuration; a bad
  field is ``raise report("key", "message")``, which the file's errors show as
  ``FILE:LINE: table.key: message``;
- its factory, ``factory(config) -> Sink``: builds the sink (nothing connects yet).

The built-in sinks are the modules ``sondalog/collect/sink_NAME.py``: :func:`find_sink`
imports the module of a name only when that table is configured (so ``psycopg`` or
``aiomqtt`` are imported only then), and the module registers itself. A sink defined
elsewhere registers itself when its module is imported (before the file is loaded).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar, overload

from sondalog.collect.model import Sink

C = TypeVar("C")
#: ``report(key, message)``: the error to raise for ``key`` of the sink's table ("" for the
#: table itself).
Report = Callable[[str, str], Exception]
Parse = Callable[[dict[str, Any], Report], C]
SinkFactory = Callable[[dict[str, Any]], Sink]

#: Where the built-in sink modules are: ``sink_NAME.py`` registers the sink ``NAME``.
_PACKAGE = "sondalog.collect"


@dataclass(frozen=True, slots=True)
class SinkKind(Generic[C]):
    """One registered sink: its table name, its config parsing and its factory."""

    table: str
    parse: Parse[C]
    factory: Callable[[C], Sink]


_KINDS: dict[str, SinkKind[Any]] = {}


class SinkError(ValueError):
    """A sink name that is unknown or whose module is missing, or a bad sink table."""


def _as_table(table: dict[str, Any], report: Report) -> dict[str, Any]:
    return dict(table)


@overload
def register_sink(table: str, factory: SinkFactory) -> None: ...


@overload
def register_sink(table: str, factory: Callable[[C], Sink], parse: Parse[C]) -> None: ...


def register_sink(
    table: str, factory: Callable[[Any], Sink], parse: Parse[Any] = _as_table
) -> None:
    """Make the sink of the ``[table]`` table known (a later registration replaces it).

    Without ``parse`` the factory gets the table as it is and checks it itself (its
    ``ValueError`` is reported at the table's line)."""
    _KINDS[table] = SinkKind(table, parse, factory)


def checking(check: Callable[[dict[str, Any]], C]) -> Parse[C]:
    """A ``parse`` from a function that checks the table itself and raises ``ValueError``
    (``NAME: message``) for a bad one: its message becomes the table's error."""

    def parse(table: dict[str, Any], report: Report) -> C:
        try:
            return check(dict(table))
        except ValueError as exc:
            raise report("", str(exc)) from None

    return parse


def checked_by(factory: Callable[[dict[str, Any]], Sink]) -> Parse[dict[str, Any]]:
    """A ``parse`` for a sink whose factory checks its own table: builds the sink once (it
    must not connect) and keeps the table as the configuration."""

    def check(table: dict[str, Any]) -> dict[str, Any]:
        factory(dict(table))
        return table

    return checking(check)


def builtin_names() -> list[str]:
    """The names of the built-in sinks: the ``sink_NAME`` modules (none is imported)."""
    package = importlib.import_module(_PACKAGE)
    return [
        info.name.removeprefix("sink_")
        for info in pkgutil.iter_modules(package.__path__)
        if info.name.startswith("sink_")
    ]


def known_names() -> list[str]:
    """Every sink name: the built-in ones and the registered ones, sorted."""
    return sorted({*builtin_names(), *_KINDS})


def find_sink(name: str) -> SinkKind[Any] | None:
    """The registration of ``name`` (importing its built-in module if need be), or ``None``
    for a name no sink has; raises :class:`SinkError` for a sink whose module is missing
    something (``psycopg`` not installed) or registers nothing."""
    kind = _KINDS.get(name)
    if kind is not None or name not in builtin_names():
        return kind
    module_name = f"{_PACKAGE}.sink_{name}"
    try:
        importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise SinkError(
            f"the {name} sink is not available: cannot import {exc.name} ({module_name})"
        ) from None
    kind = _KINDS.get(name)
    if kind is None:
        raise SinkError(f"{module_name} registers no sink (register_sink({name!r}, ...))")
    return kind


def load_sink(name: str, table: Mapping[str, Any]) -> Sink:
    """Build the sink ``name`` from its configuration table.

    Raises :class:`SinkError` for an unknown name or a missing module, and ``ValueError``
    (``NAME.KEY: message``) for a bad table.
    """
    kind = find_sink(name)
    if kind is None:
        raise SinkError(f"unknown sink {name!r} (known: {', '.join(known_names())})")

    def report(key: str, message: str) -> Exception:
        if message.startswith(f"{name}.") or message.startswith(f"{name}:"):
            return ValueError(message)
        return ValueError(f"{name}.{key}: {message}" if key else f"{name}: {message}")

    return kind.factory(kind.parse(dict(table), report))


class SinkPlan(Protocol):
    """What :func:`build_sinks` needs of a loaded configuration
    (:class:`~sondalog.collect.config.CollectorConfig`): the parsed sink tables, and the
    error for one with the table's line."""

    @property
    def sinks(self) -> Mapping[str, Any]: ...

    def sink_error(self, name: str, exc: Exception) -> Exception: ...


def build_sinks(config: SinkPlan) -> list[Sink]:
    """Every sink of ``config`` built from its parsed configuration (nothing connects yet);
    raises :class:`~sondalog.collect.config.ConfigError` with the table's line for a sink
    whose factory refuses it. ``collect --check`` calls it too, so it finds whatever a start
    would."""
    sinks: list[Sink] = []
    for name, sink_config in config.sinks.items():
        try:
            kind = find_sink(name)
            if kind is None:
                raise SinkError(f"unknown sink {name!r} (known: {', '.join(known_names())})")
            sinks.append(kind.factory(sink_config))
        except ValueError as exc:
            raise config.sink_error(name, exc) from None
    return sinks
