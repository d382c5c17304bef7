"""What leaves the logger by itself: messages and command replies on their way out (§6.14).

The contract between the part of the core that decides *what* to send and *when*
(:mod:`sondalog.ala1.messages`: triggers, bodies, blocking) and the parts that *carry* it: the
cable line itself for ``com device local`` (plain text on the line), or the logger's modem
driver for ``com device wavecom`` (SMS, e-mail through the GSM/GPRS modem). A carrier takes
an :class:`Outgoing` from the :class:`Outbox`, delivers it to every destination, and reports
the result with :meth:`Outbox.done`; only then does a ``read record N from lastread shift``
message move its point (§6.8.4.1). A failed delivery is retried at the message's next trigger.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

Kind = Literal["sms", "email", "local"]


@dataclass(frozen=True, slots=True)
class Destination:
    """Where one copy goes: an SMS number, an e-mail address (with the SMTP server given
    after the address value, §6.10.3, if any), or the cable line."""

    kind: Kind
    address: str = ""
    server: str | None = None


@dataclass(frozen=True, slots=True)
class Outgoing:
    """One sending: message ``message`` (1..40; 0 for a reply to a command received by SMS,
    e-mail or a call), to ``destinations``, with ``body`` exactly as a line would carry the
    response of the message's named command (lines ending CR LF, the final ``OK`` or error
    response included)."""

    ident: int
    message: int
    destinations: tuple[Destination, ...]
    body: str
    subject: str | None = None  # e-mail subject (``email send subject``), None = default


#: Called with (ident, every destination delivered?) when a carrier has finished a sending.
Done = Callable[[int, bool], None]


class Outbox:
    """The queue between the message logic and the carriers (RAM, like the module's)."""

    def __init__(self) -> None:
        self._queue: deque[Outgoing] = deque()
        self._next = 1
        self._listeners: list[Done] = []
        #: Set by the modem driver while the modem is in use (a data call, a TCP client,
        #: SMS being read and answered): messages wait until it is cleared (§6.14.9.1).
        self.modem_busy = False

    def new_ident(self) -> int:
        ident, self._next = self._next, self._next + 1
        return ident

    def put(self, outgoing: Outgoing) -> None:
        self._queue.append(outgoing)

    def peek(self, kind: Kind | None = None) -> Outgoing | None:
        """The oldest sending (with a destination of ``kind``, if given), left in place."""
        for outgoing in self._queue:
            if kind is None or any(d.kind == kind for d in outgoing.destinations):
                return outgoing
        return None

    def take(self, kind: Kind | None = None) -> Outgoing | None:
        """Remove and return what :meth:`peek` would return."""
        outgoing = self.peek(kind)
        if outgoing is not None:
            self._queue.remove(outgoing)
        return outgoing

    def withdraw(self, ident: int) -> Outgoing | None:
        """Remove sending ``ident`` if no carrier has taken it yet."""
        for outgoing in self._queue:
            if outgoing.ident == ident:
                self._queue.remove(outgoing)
                return outgoing
        return None

    def __len__(self) -> int:
        return len(self._queue)

    def on_done(self, listener: Done) -> None:
        self._listeners.append(listener)

    def done(self, ident: int, ok: bool) -> None:
        """A carrier finished sending ``ident``; ``ok`` when every destination got it."""
        for listener in self._listeners:
            listener(ident, ok)
