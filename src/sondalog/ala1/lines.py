"""The state of one line of an ALA1 module (§3.4, spec notes §1) and of an XMODEM transfer
running on it (§6.16), and the bound on what a line holds while a command waits (issue 20);
the line discipline is :class:`~sondalog.ala1.engine.Engine`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.ala1.pacing import Pacer
from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender

#: The most bytes a line holds while a command waits (§6.11.1 forbids sending then; a real
#: module's receive FIFO is small): what comes beyond is lost, as in a FIFO overrun (issue 20).
BACKLOG_MAX = 4096


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
    overrun: bool = False  # bytes after the backlog were lost (BACKLOG_MAX)
    blocks_messages: bool = False  # §6.14.9.2
    transfer: Transfer | None = None
    ident: int = 0  # the line id

    def hold(self, data: bytes) -> None:
        """Keep ``data`` received while a command waits, up to :data:`BACKLOG_MAX` bytes."""
        room = self.room()
        if room is not None and len(data) > room:
            data = data[:room]
            self.overrun = True  # and nothing more is kept: no gap inside the backlog
        self.backlog += data

    def take_backlog(self) -> tuple[bytes, bool]:
        """What was held while a command waited, and whether bytes after it were lost;
        the line holds nothing after."""
        held, lost = bytes(self.backlog), self.overrun
        self.backlog, self.overrun = bytearray(), False
        return held, lost

    def room(self) -> int | None:
        """How many more bytes the line can take without losing any (None: no bound, the
        line discipline bounds what it keeps, §3.4.1)."""
        if self.pending is None:
            return None
        return 0 if self.overrun else max(BACKLOG_MAX - len(self.backlog), 0)

    def lost_after_backlog(self, now: float) -> None:
        """Bytes were lost after the backlog just run (issue 20): the command line they
        belonged to gets the error response when it ends, as a line past 120 characters
        does (§3.4.1); it never runs with a piece missing."""
        if self.pending is not None:  # the backlog's rest waits again: the loss is after it
            self.overrun = True
        elif self.transfer is None:
            self.overflow = True
            if self.started is None:
                self.started = now  # and the entry timeout (§3.4.5) ends it

    def idle(self) -> bool:
        """Nothing on the line waits: no command, no partial line, no transfer, no output."""
        return (
            self.pending is None
            and self.started is None
            and self.transfer is None
            and self.pacer.idle()
        )

    def deadlines(self, entry_timeout: float, scale: float) -> list[float]:
        """When the line needs its engine next (host clock): the waiting command's run, the
        entry timeout of a partial line (§3.4.5, ``entry_timeout`` host seconds), the
        transfer's grace or its peer's next step, the paced output (``scale``: module
        seconds to host seconds)."""
        out: list[float] = []
        if self.pending is not None:
            out.append(self.run_at)
        elif self.started is not None:
            out.append(self.started + entry_timeout)
        if (transfer := self.transfer) is not None:
            if transfer.grace_until is not None:
                out.append(transfer.grace_until)
            elif (due := transfer.peer.next_deadline()) is not None:
                out.append(due * scale)
        if (paced := self.pacer.next_deadline()) is not None:
            out.append(paced * scale)
        return out
