"""The ``sqlite`` sink under the ``sink_*`` name the other sinks use (see
:mod:`sondalog.collect.store_sqlite`, where it lives). The collector's own ``[sqlite]`` table
is its store, read by the same :func:`~sondalog.collect.store_sqlite.parse_store`; this
registration builds such a store by name like any other sink."""

from sondalog.collect.sinks import register_sink
from sondalog.collect.store_sqlite import SqliteStore, create, open_store, parse_store

__all__ = ["SqliteStore", "create"]

register_sink("sqlite", open_store, parse_store)
