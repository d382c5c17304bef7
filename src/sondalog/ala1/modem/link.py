"""The glue between the engine and its modem driver (the driver's :class:`Host`).

When the logger's com line is a modem line (``com device wavecom4x``), the engine hands that
line's bytes to :class:`ModemLink`, which gives them to the driver; while no modem answers,
the line works as ``local`` and its bytes go to the command parser as before. Commands from
SMS and e-mail run through :func:`execute` (no line: no echo, the answer's bytes); command
sessions (data call, port 10001) get a private engine line each.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Protocol

from sondalog.ala1.headers import MAX_LINE
from sondalog.ala1.interpreter import Interpreter
from sondalog.ala1.model import Identity
from sondalog.ala1.modem.credit import ModemHardware
from sondalog.ala1.modem.driver import ModemDriver
from sondalog.ala1.modem.text import normalize_number
from sondalog.ala1.outbox import Outbox
from sondalog.ala1.state import ModuleState, NeedWait

log = logging.getLogger(__name__)


class LinkEngine(Protocol):
    """What the link needs of its engine (:class:`sondalog.ala1.engine.Engine`, which
    passes itself): line time, the module, its interpreter, and lines to open, feed, drain,
    write and close."""

    @property
    def scale(self) -> float: ...
    @property
    def identity(self) -> Identity: ...
    @property
    def state(self) -> ModuleState: ...
    @property
    def interpreter(self) -> Interpreter: ...
    def open_line(self, *, paced: bool = False) -> int: ...
    def accept(self, line_id: int, data: bytes, now: float) -> None: ...
    def take_line_output(self, line_id: int, now: float) -> bytes: ...
    def write_line(self, line_id: int, data: bytes, now: float) -> None: ...
    def close_line(self, line_id: int) -> None: ...


def execute(engine: LinkEngine, text: str, now: float, paused: bool = False) -> bytes | float:
    """Run command line ``text`` as a line would (§3.4.6): its answer bytes, or the seconds
    to wait (``pause``, a sensor) before asking again with ``paused=True``."""
    engine.state.run_sampling(now)
    overflow = len(text) > MAX_LINE
    line = text[:MAX_LINE]
    try:
        answer = engine.interpreter.run_line(line, now, overflow=overflow, paused=paused)
    except NeedWait as wait:
        return wait.seconds * (engine.scale if wait.line_time else 1.0)
    except Exception:  # DESIGN.md point 6: never stop the device
        log.exception("internal error on %r", line)
        answer = engine.interpreter.error_answer(line)
    return b"" if answer is None else answer.data


class ModemLink:
    """The engine's modem line and its driver.

    The driver works in line time (docs/decisions.md "Time base"): its timeouts (the 1 s AT
    probe, the 2-minute idle hang-up, mail timeouts) are real seconds even at ``--speed``.
    The link converts: clock time / ``engine.scale`` going in, times ``scale`` coming out."""

    def __init__(
        self, engine: LinkEngine, line: int, now: float, outbox: Outbox | None = None
    ) -> None:
        self.engine = engine
        self.scale = engine.scale
        self.line = line
        self.outbox = outbox if outbox is not None else Outbox()
        #: Called with (message, now) by a ``ringvoice``/``ringdata`` call (§6.10.2.3-4).
        self.on_ring: Callable[[int, float], None] | None = None
        self.sessions: set[int] = set()
        self._quiet_since = now / self.scale
        self.driver = ModemDriver(self, now / self.scale)
        state = engine.state
        hardware = ModemHardware(state.hardware, self.driver.readings)
        state.hardware = hardware
        state.measurer.hardware = hardware
        state.on_demand.forget()  # compiled against the hardware it replaces

    # -- from the engine -----------------------------------------------------------------
    def receive(self, data: bytes, now: float) -> bool:
        """Bytes on the modem line; False: the line works as ``local``."""
        self._quiet_since = now / self.scale
        return self.driver.receive(data, now / self.scale)

    def advance(self, now: float) -> None:
        self.driver.advance(now / self.scale)

    def next_deadline(self) -> float | None:
        due = self.driver.next_deadline()
        return None if due is None else due * self.scale

    def pump(self, now: float) -> None:
        """Carry the sessions' answers to the driver and the driver's bytes to the line."""
        for session in self.sessions:
            data = self.engine.take_line_output(session, now)
            if data:
                self.driver.session_output(data)
        out = self.driver.take_output()
        if out:
            self.engine.write_line(self.line, out, now)

    @property
    def busy(self) -> bool:
        return self.driver.busy

    # -- Host ----------------------------------------------------------------------------
    def setting(self, name: str) -> str:
        return self.engine.state.get(name)

    def execute(self, text: str, now: float, paused: bool) -> bytes | float:
        """(Called by the driver in line time: a wait comes back in line seconds too.)"""
        answer = execute(self.engine, text, now * self.scale, paused)
        return answer / self.scale if isinstance(answer, float) else answer

    def open_session(self, now: float) -> int:
        session = self.engine.open_line()
        self.sessions.add(session)
        return session

    def session_input(self, session: int, data: bytes, now: float) -> None:
        self.engine.accept(session, data, now * self.scale)

    def close_session(self, session: int) -> None:
        self.sessions.discard(session)
        self.engine.close_line(session)

    def ring_message(self, kind: str, number: str) -> int | None:
        wanted = "RINGVOICE" if kind == "voice" else "RINGDATA"
        caller = normalize_number(number)
        for index in range(1, self.engine.identity.limits.addresses + 1):
            kind_value = self.setting(f"address {index} type")
            name, _, message = kind_value.partition(",")
            if name != wanted or not message.strip().isdigit():
                continue
            if normalize_number(self.setting(f"address {index} value")) == caller:
                return int(message)
        return None

    def run_message(self, message: int, now: float) -> None:
        if self.on_ring is not None:
            self.on_ring(message, now * self.scale)
        else:
            log.info("message %d triggered by a call: no message logic attached", message)

    def line_quiet_since(self) -> float:
        return self._quiet_since
