"""A simulated modem on a real pty, for real peers (gammu) in tests.

A pump thread reads the pty's master side and feeds the bytes, with ``time.monotonic()``
(shifted once to the epoch, so SMS timestamps read as today), into a
:class:`~sondalog.gsm.system.GsmSystem`; what the modem answers is written back. The peer
opens :attr:`ModemPty.path` (``/dev/pts/N``) like a serial port. Tests change the world
through :meth:`ModemPty.call` (under the pump's lock).
"""

from __future__ import annotations

import os
import pty
import select
import threading
import time
import tty
from collections.abc import Callable
from typing import TypeVar

from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.system import GsmSystem, SystemOutput

T = TypeVar("T")

_EPOCH = time.time() - time.monotonic()


def clock() -> float:
    """Monotonic seconds on the POSIX epoch."""
    return time.monotonic() + _EPOCH


class ModemPty:
    def __init__(self, number: str = "+420600000001", config: ModemConfig | None = None) -> None:
        self.number = number
        self.system = GsmSystem()
        self.trace: list[tuple[str, bytes, float]] = []
        self.modem = Modem(config, trace=lambda d, b, t: self.trace.append((d, b, t)))
        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.errors: list[BaseException] = []
        self._thread = threading.Thread(target=self._pump, daemon=True)
        self._write(self.system.add_modem(number, self.modem, clock()))

    def __enter__(self) -> ModemPty:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(5)
        os.close(self.master)
        os.close(self.slave)

    def call(self, fn: Callable[[GsmSystem, float], T]) -> T:
        """Run ``fn(system, now)`` under the pump's lock; write what it outputs."""
        with self._lock:
            result = fn(self.system, clock())
            if isinstance(result, SystemOutput):
                self._write(result)
            return result

    def rx(self) -> bytes:
        """Everything the peer sent so far."""
        return b"".join(b for d, b, _ in self.trace if d == "rx")

    def _write(self, out: SystemOutput) -> None:
        data = out.line(self.number)
        while data:
            n = os.write(self.master, data)
            data = data[n:]

    def _pump(self) -> None:
        try:
            self._loop()
        except BaseException as exc:  # recorded for the test: gammu would only hang
            self.errors.append(exc)
            raise

    def _loop(self) -> None:
        while not self._stop.is_set():
            now = clock()
            deadline = self.system.next_deadline(now)
            timeout = 0.1 if deadline is None else max(0.0, min(0.1, deadline - now))
            ready, _, _ = select.select([self.master], [], [], timeout)
            with self._lock:
                now = clock()
                if ready:
                    try:
                        data = os.read(self.master, 4096)
                    except OSError:  # the peer closed the slave side: nothing to read yet
                        data = b""
                    if data:
                        self._write(self.system.modem_input(self.number, data, now))
                self._write(self.system.advance(now))
