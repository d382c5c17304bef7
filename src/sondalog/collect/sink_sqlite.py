"""The ``sqlite`` sink under the ``sink_*`` name the other sinks use (see
:mod:`sondalog.collect.store_sqlite`, where it lives)."""

from sondalog.collect.store_sqlite import SqliteStore, create

__all__ = ["SqliteStore", "create"]
