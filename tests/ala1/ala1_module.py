"""A harness around the pure ALA1 engine: bytes in, bytes out, time stepped by the test."""

from __future__ import annotations

from pathlib import Path

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.hardware import Hardware
from sondalog.backends.store.ala1_nv import SqliteNvStore

T0 = 1_000_000_000.0


class Module:
    """One virtual ALA1 on one line, driven by a test."""

    def __init__(
        self,
        version: Version = Version.V2_10,
        db: str | Path = ":memory:",
        hardware: Hardware | None = None,
        now: float = T0,
    ) -> None:
        self.now = now
        self.store = SqliteNvStore(db)
        self.engine = Engine(Identity(version), self.store, self.now, hardware)
        self.line = self.engine.open_line()

    def feed(self, data: bytes) -> bytes:
        """Send raw bytes; return everything the module sends back."""
        out = self.engine.receive(self.line, data, self.now)
        assert all(o.line == self.line for o in out)
        return b"".join(o.data for o in out)

    def ask(self, command: str | bytes) -> bytes:
        """Send one command line terminated by CR."""
        raw = command.encode("latin-1") if isinstance(command, str) else command
        return self.feed(raw + b"\r")

    def ok(self, command: str) -> None:
        assert self.ask(command) == b"OK\r\n", command

    def read(self, command: str) -> str:
        """Run a read command; return its single data line."""
        answer = self.ask(command)
        assert answer.endswith(b"\r\nOK\r\n"), (command, answer)
        return answer[: -len(b"\r\nOK\r\n")].decode("latin-1")

    def error(self, command: str) -> None:
        assert self.ask(command) == command.encode("latin-1")[:120] + b"\r\nERROR\r\n", command

    def advance(self, seconds: float) -> bytes:
        self.now += seconds
        return b"".join(o.data for o in self.engine.advance(self.now))

    def settle(self, command: str, limit: float = 120.0) -> bytes:
        """Send a command and step the clock through its waits (switch advance,
        DS18B20 conversion) until the answer comes."""
        answer = self.ask(command)
        waited = 0.0
        while not answer and waited < limit:
            deadline = self.engine.next_deadline()
            assert deadline is not None
            step = max(deadline - self.now, 0.0)
            waited += step
            answer = self.advance(step)
        return answer
