"""The web dashboard over the collector's store: overview, plots, log, CSV, live updates.

It reads the SQLite store whose schema is :mod:`sondalog.collect.schema` and nothing else.
See ``docs/dashboard.md``.
"""

from __future__ import annotations

from .app import Settings, create_app
from .server import check_listen, serve

__all__ = ["Settings", "check_listen", "create_app", "serve"]
