"""Sinks by name: the collector's ``[sqlite]``, ``[postgres]`` and ``[mqtt]`` tables.

A sink module either calls :func:`register_sink` when imported or exposes a module-level
``create(table) -> Sink``. :func:`load_sink` imports the module of a known name lazily (so
``psycopg`` or ``aiomqtt`` are imported only when configured) and builds the sink from its
configuration table.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

from sondalog.collect.config import CollectorConfig
from sondalog.collect.model import Sink

SinkFactory = Callable[[dict[str, Any]], Sink]

#: The module of each built-in sink name.
MODULES: dict[str, str] = {
    "sqlite": "sondalog.collect.store_sqlite",
    "postgres": "sondalog.collect.sink_postgres",
    "mqtt": "sondalog.collect.sink_mqtt",
}
_FACTORIES: dict[str, SinkFactory] = {}


class SinkError(ValueError):
    """A sink name that is unknown or whose module is missing, or a bad sink table."""


def register_sink(name: str, factory: SinkFactory) -> None:
    """Make ``name`` available to :func:`load_sink` (a later registration replaces it)."""
    _FACTORIES[name] = factory


def load_sink(name: str, table: Mapping[str, Any]) -> Sink:
    """Build the sink ``name`` from its configuration table.

    Raises :class:`SinkError` for an unknown name or a missing module, and passes on the
    factory's ``ValueError`` for a bad table (the message names the field).
    """
    factory = _FACTORIES.get(name)
    if factory is None:
        module_name = MODULES.get(name)
        if module_name is None:
            known = ", ".join(sorted({*MODULES, *_FACTORIES}))
            raise SinkError(f"unknown sink {name!r} (known: {known})")
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            raise SinkError(
                f"the {name} sink is not available: cannot import {exc.name} ({module_name})"
            ) from None
        factory = _FACTORIES.get(name) or getattr(module, "create", None)
        if factory is None:
            raise SinkError(f"{module_name} neither registers a sink nor has create()")
    return factory(dict(table))


def build_sinks(config: CollectorConfig) -> list[Sink]:
    """Every sink table of ``config`` built (nothing connects yet); raises
    :class:`~sondalog.collect.config.ConfigError` with the table's line for a bad table, an
    unknown sink or a sink whose module is missing. ``collect --check`` calls it too, so it
    finds whatever a start would."""
    sinks: list[Sink] = []
    for name, table in config.sinks.items():
        try:
            sinks.append(load_sink(name, table))
        except ValueError as exc:
            raise config.sink_error(name, exc) from None
    return sinks
