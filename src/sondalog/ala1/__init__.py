"""The ALA1 data logger, device side (manual protocol 1.16 and 2.10).

Public front door (DESIGN.md point 7): :class:`Engine` (the pure core), :class:`Identity`,
:class:`Version` (lines' output: :class:`~sondalog.protocol.device.LineSend`).
"""

from sondalog.ala1.engine import Engine
from sondalog.ala1.model import Identity, Version

__all__ = ["Engine", "Identity", "Version"]
