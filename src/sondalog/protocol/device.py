"""The contract between a device core and the runtime (DESIGN.md point 1; h11's shape).

A core (the ALA1 engine, the RS-485 bus with its HCTMPS1 modules, later the GSM modem and
network) is a :class:`Device`: bytes received on its lines and typed :class:`Event` objects go
in together with the clock's ``now``; typed :class:`Effect` objects come out, and the core says
when it next needs to be woken (:meth:`Device.next_deadline`). The one runtime
(:class:`sondalog.io.host.DeviceHost`) serves any core this way. New features add event and
effect types; the runtime routes an effect it does not handle itself to the handler registered
for its type, so messages, a modem or a mail hub never touch the runtime.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol


class Effect:
    """Something a core asks the world to do (base class)."""

    __slots__ = ()


class Event:
    """Something that happened to a core, other than bytes on a line (base class)."""

    __slots__ = ()


@dataclass(frozen=True, slots=True)
class LineSend(Effect):
    """Bytes for one line, and the baud rate they were paced at (None: unpaced)."""

    line: int
    data: bytes
    baud: int | None = None


class Device(Protocol):
    """A pure core served by the runtime."""

    def open_line(self, *, paced: bool = False) -> int:
        """Attach a line (a TCP connection, a pty, a serial port, an in-process link).

        ``paced``: the core releases the line's output at the line's rate."""
        ...

    def close_line(self, line: int) -> None:
        """The line is gone (disconnected)."""
        ...

    def line_speed(self) -> int:
        """The rate the core's lines run at now (ALA1 ``com speed``, the bus baud rate)."""
        ...

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        """Bytes received on ``line`` at ``now``; returns what to do now."""
        ...

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        """A typed event at ``now``; returns what to do now."""
        ...

    def advance(self, now: float) -> Sequence[Effect]:
        """Run what is due at ``now``."""
        ...

    def next_deadline(self) -> float | None:
        """When the core next needs :meth:`advance` (None: only on input)."""
        ...
