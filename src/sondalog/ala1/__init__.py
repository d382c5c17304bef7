"""The ALA1 data logger, device side (manual protocol 1.16 and 2.10).

Public front door (DESIGN.md point 7): :class:`Engine` (the pure core), :class:`Identity`,
:class:`Version`, :class:`Output`.
"""

from sondalog.ala1.engine import Engine, Output
from sondalog.ala1.model import Identity, Version

__all__ = ["Engine", "Identity", "Output", "Version"]
