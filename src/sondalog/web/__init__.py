"""The web dashboard over the collector's store: overview, plots, log, CSV, live updates.

It reads the collector's store whose schema is :mod:`sondalog.collect.schema`: the readings
from its SQLite file or the ``[postgres]`` server (:mod:`.db`), long ranges from the
per-block extremes when the store keeps them (:mod:`.blocks`). See ``docs/dashboard.md``.
"""

from __future__ import annotations

from .app import Settings, create_app
from .server import check_listen, serve

__all__ = ["Settings", "check_listen", "create_app", "serve"]
