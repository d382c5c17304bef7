"""A virtual ALA1 for scripts and tests: engine, store, simulated hardware, stepped clock.

This is the test and control hook of the simulation (docs/simulation.md): it sends command
lines, steps module time forward (running every sample in between) and changes signals.
"""

from __future__ import annotations

from pathlib import Path

from sondalog.ala1.engine import Engine
from sondalog.ala1.model import Identity, Version
from sondalog.backends.sim.logger import SimHardware, default_hardware
from sondalog.backends.sim.logger_site import load_logger_site
from sondalog.backends.sim.signals import Signal
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.io.clock import SteppedClock

#: Host-clock start of a virtual logger's world (any fixed value; the module clock is set
#: with ``write date``).
START = 1_000_000_000.0


class VirtualLogger:
    """One virtual ALA1 driven directly from Python."""

    def __init__(
        self,
        *,
        database: Path | str = ":memory:",
        version: Version = Version.V2_10,
        serial_number: str = "000001",
        site: Path | str | None = None,
        hardware: SimHardware | None = None,
        start: float = START,
    ) -> None:
        self.clock = SteppedClock(start)
        if hardware is None:
            hardware = (
                load_logger_site(Path(site), start) if site is not None else default_hardware(start)
            )
        self.hardware = hardware
        self.store = SqliteNvStore(database)
        self.engine = Engine(Identity(version, serial_number), self.store, start, hardware)
        self.line = self.engine.open_line()

    def send(self, data: bytes) -> bytes:
        """Raw bytes in, raw bytes out (no waiting)."""
        out = self.engine.receive(self.line, data, self.clock.now())
        return b"".join(o.data for o in out if o.line == self.line)

    def command(self, line: str, *, max_wait: float = 3600.0) -> str:
        """Run one command line; step the clock through switch advances, conversions and
        ``pause`` until the answer comes. Returns the answer text (CR LF line ends)."""
        answer = self.send(line.encode("latin-1") + b"\r")
        waited = 0.0
        while not answer and waited < max_wait:
            deadline = self.engine.next_deadline()
            if deadline is None:
                break
            step = max(0.0, deadline - self.clock.now())
            waited += step
            answer = self._advance(step)
        return answer.decode("latin-1")

    def step(self, seconds: float) -> None:
        """Let ``seconds`` of time pass, taking every scheduled sample on the way."""
        self._advance(seconds)

    def _advance(self, seconds: float) -> bytes:
        now = self.clock.advance(seconds)
        return b"".join(o.data for o in self.engine.advance(now) if o.line == self.line)

    def set_signal(self, what: str, signal: Signal | float) -> None:
        """Change the world: see :meth:`sondalog.backends.sim.logger.SimHardware.set_signal`."""
        self.hardware.set_signal(what, signal)

    def write_file(self, area: str, data: bytes) -> None:
        """Place a table file (``list`` or ``data``) in the memory (§10.4)."""
        self.engine.state.write_file(area, data)

    def close(self) -> None:
        self.store.close()
