"""The ``sim`` hardware backend: seeded signal models and site files (DESIGN.md point 4).

Its registry entry (:mod:`sondalog.backends.registry`): :func:`plan` reads the site file's
``[logger]`` table into a :class:`~sondalog.backends.sim.logger_site.SimPlan` when the file
is loaded, :func:`create` builds the hardware from that plan at start. A simulation serves
any number of loggers (a fleet builds one hardware per logger from one plan).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sondalog.ala1.hardware import Hardware
    from sondalog.backends.registry import BackendContext
    from sondalog.backends.sim.logger_site import SimPlan
    from sondalog.config import Table


def plan(logger: Table) -> SimPlan:
    """The checked description of the ``[logger]`` table; raises
    :class:`~sondalog.config.ConfigError` naming file, line and field."""
    from sondalog.backends.sim.logger_site import plan_logger

    return plan_logger(logger)


def create(context: BackendContext) -> Hardware:
    """Simulated hardware from the plan made at load (else from the site file's ``[logger]``
    table; a 12 V supply and nothing else without one)."""
    from sondalog.backends.sim.logger_site import SimPlan, plan_site
    from sondalog.config import of

    made = context.plan
    if not isinstance(made, SimPlan):
        made = plan_site(of(context.site, context.path, context.text))
    return made.build(context.start)
