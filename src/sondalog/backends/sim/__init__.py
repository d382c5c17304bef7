"""The ``sim`` hardware backend: seeded signal models and site files (DESIGN.md point 4)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sondalog.ala1.hardware import Hardware
    from sondalog.backends.registry import BackendContext


def create(context: BackendContext) -> Hardware:
    """Simulated hardware from the site file's ``[logger]`` table (a 12 V supply and nothing
    else without one); raises :class:`~sondalog.config.ConfigError` naming file, line and field."""
    from sondalog.backends.sim.logger import parse_logger_site

    return parse_logger_site(context.site, context.start, context.path, context.text)
