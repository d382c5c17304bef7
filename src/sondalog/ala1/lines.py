"""The state of one line of an ALA1 module (§3.4, spec notes §1) and of an XMODEM transfer
running on it (§6.16): data only; the line discipline is :class:`~sondalog.ala1.engine.Engine`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.ala1.pacing import Pacer
from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender


@dataclass
class Transfer:
    """An XMODEM transfer running on a line (§6.16)."""

    command: str  # the command line, for its error response
    area: str
    peer: XmodemSender | XmodemReceiver
    speed: int | None
    grace_until: float | None = None  # set once the transfer is over


@dataclass
class Line:
    """Line state of one connection (§3.4)."""

    pacer: Pacer
    buffer: list[str] = field(default_factory=list)
    echo: bool = False
    started: float | None = None  # time of the first character of the command
    overflow: bool = False
    pending: str | None = None  # a complete command waiting for its pause or sensors
    run_at: float = 0.0
    speed: int | None = None  # the rate the waiting command's answer goes at
    backlog: bytearray = field(default_factory=bytearray)  # received while a command waits
    blocks_messages: bool = False  # §6.14.9.2
    transfer: Transfer | None = None
    ident: int = 0  # the line id
