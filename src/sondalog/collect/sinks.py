"""Sinks by name: a collector sink is one module and one :func:`register_sink` call.

A registration carries all the collector needs to know about the sink:

- its TOML table name (``[postgres]``, ``[mqtt]``, ...): the configuration file accepts a
  top-level table of every registered name (:mod:`sondalog.collect.config`), no edit there;
- its config parsing, ``parse(table) -> config``: ``table`` is the sink's
  :class:`sondalog.config.Table` (typed getters; ``table.keys(...)`` refuses unknown keys with
  a "did you mean"; relative paths are relative to the file's directory). It checks the table
  when the file is loaded (``collect --check`` and a start alike), returns a typed
  configuration and raises :class:`~sondalog.config.ConfigError` (``table.fail(key, ...)``,
  or any getter), shown as ``FILE:LINE: table.key: message``;
- its factory, ``factory(config) -> Sink``: builds the sink from the checked configuration
  (nothing connects yet, nothing is refused any more).

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
from typing import Any, Generic, TypeVar

from sondalog.collect.model import Sink
from sondalog.config import Table

C = TypeVar("C")
#: ``parse(table) -> config``: the sink's table checked (raises ``ConfigError``).
Parse = Callable[[Table], C]

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
    """A sink name that is unknown or whose module is missing something."""


def register_sink(table: str, factory: Callable[[C], Sink], parse: Parse[C]) -> None:
    """Make the sink of the ``[table]`` table known (a later registration replaces it)."""
    _KINDS[table] = SinkKind(table, parse, factory)


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


def build_sinks(sinks: Mapping[str, Any]) -> list[Sink]:
    """Every sink of a loaded configuration (``CollectorConfig.sinks``: name -> what its
    ``parse`` returned) built by its factory; nothing connects yet. ``collect --check`` calls
    it too, so it builds whatever a start would."""
    built: list[Sink] = []
    for name, config in sinks.items():
        kind = find_sink(name)
        if kind is None:
            raise SinkError(f"unknown sink {name!r} (known: {', '.join(known_names())})")
        built.append(kind.factory(config))
    return built
