"""The web dashboard over the collector's store: overview, plots, log, CSV, live updates.

It reads the SQLite store whose schema is :mod:`sondalog.collect.schema` and nothing else.
See ``docs/dashboard.md``.
"""

from __future__ import annotations

from .app import Settings, create_app
from .server import WebConfigError, check_listen, is_loopback, serve

__all__ = ["Settings", "WebConfigError", "check_listen", "create_app", "is_loopback", "serve"]
