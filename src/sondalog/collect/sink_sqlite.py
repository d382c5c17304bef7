"""The ``sqlite`` sink under the ``sink_*`` name the other sinks use (see
:mod:`sondalog.collect.store_sqlite`, where it lives). The collector's own ``[sqlite]`` table
is its store, not a sink table; :func:`~sondalog.collect.sinks.load_sink` builds it by name."""

from sondalog.collect.sinks import checked_by, register_sink
from sondalog.collect.store_sqlite import SqliteStore, create

__all__ = ["SqliteStore", "create"]

register_sink("sqlite", create, checked_by(create))
