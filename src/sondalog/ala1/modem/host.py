"""The modem package's two seams: what the driver needs from the logger (:class:`Host`,
:class:`~sondalog.ala1.modem.link.ModemLink` is the one the engine gives it), and what a job
needs of the driver that runs it (:class:`Driver`,
:class:`~sondalog.ala1.modem.driver.ModemDriver` passes itself). The jobs
(:mod:`~sondalog.ala1.modem.jobs`, :mod:`~sondalog.ala1.modem.mailjobs`,
:mod:`~sondalog.ala1.modem.session`) import this module, never the driver."""

from __future__ import annotations

from collections import deque
from typing import Protocol

from sondalog.ala1.modem.atio import ModemReader, PendingReply
from sondalog.ala1.modem.credit import GsmReadings
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


class Driver(Protocol):
    """What a job needs of the driver running it
    (:class:`~sondalog.ala1.modem.driver.ModemDriver`): the time of the resumption, the
    logger, the line's reader, and the modem's state as the jobs read and set it. The
    attributes are the driver's own; see it for their meaning."""

    host: Host
    now: float
    reader: ModemReader
    readings: GsmReadings
    present: bool | None
    applied: str | None
    radio: bool
    gprs: bool
    listening: bool
    registered_since: float | None
    session: int | None
    replies: deque[PendingReply]
    listing_due: bool
    heard: bool
    resync: bool
    stray_finals: int
    outstanding: int
    last_timeout: float

    def take_lines(self) -> None: ...

    def keep_looking(self) -> None: ...

    def drop_urcs(self, exact: str) -> None: ...

    def out_of_step(self, why: str) -> None: ...

    def found(self, answered: bool) -> None: ...

    def network_back(self) -> None: ...
