"""What the modem driver needs from the logger: its :class:`Host`
(:class:`~sondalog.ala1.modem.link.ModemLink` is the one the engine gives it)."""

from __future__ import annotations

from typing import Protocol

from sondalog.ala1.outbox import Outbox


class Host(Protocol):
    """What the driver needs from the logger (:class:`~sondalog.ala1.modem.link.ModemLink`)."""

    outbox: Outbox

    def setting(self, name: str) -> str: ...

    def execute(self, text: str, now: float, paused: bool) -> bytes | float:
        """The answer bytes of command line ``text``, or seconds to wait and ask again."""
        ...

    def open_session(self, now: float) -> int: ...

    def session_input(self, session: int, data: bytes, now: float) -> None: ...

    def close_session(self, session: int) -> None: ...

    def ring_message(self, kind: str, number: str) -> int | None:
        """The message of a ``ringvoice``/``ringdata`` address with this number (§6.10.2)."""
        ...

    def run_message(self, message: int, now: float) -> None: ...

    def line_quiet_since(self) -> float: ...
