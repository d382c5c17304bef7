"""Test support for the bus: an asyncio event loop that runs on virtual time.

``VirtualTimeLoop`` is a normal selector event loop whose ``time()`` is a counter: when the
loop would block waiting for a timer and no I/O is ready, the counter jumps to the timer
instead. Everything built on the loop's time (``asyncio.sleep``, ``wait_for``, and the bus's
:class:`~sondalog.io.bus_runner.LoopClock`) then runs in virtual time: a minute of 9600-baud bus
traffic takes milliseconds and never depends on the machine's speed. Only for tests without
real I/O.
"""

from __future__ import annotations

import asyncio
import random
import select
import selectors
import signal
import subprocess
import sys
from collections.abc import Callable, Coroutine
from pathlib import Path
from typing import Any, TypeVar

from sondalog.hctmps1 import HUM, TEMP, Hctmps1Module, MemoryEeprom, ModuleConfig, slot_time
from sondalog.io.clock import LoopClock
from sondalog.io.host import DeviceHost
from sondalog.world.bus import BusCore

T = TypeVar("T")
START = 1_000_000.0


class _VirtualSelector(selectors.DefaultSelector):
    def __init__(self) -> None:
        super().__init__()
        self.now = 0.0

    def select(self, timeout: float | None = None) -> list[Any]:
        events: list[Any] = super().select(0)
        if events or timeout is None or timeout <= 0:
            return events if events or timeout is not None else super().select(None)
        self.now += timeout
        return []


class VirtualTimeLoop(asyncio.SelectorEventLoop):
    def __init__(self) -> None:
        self._virtual = _VirtualSelector()
        super().__init__(self._virtual)

    def time(self) -> float:
        return self._virtual.now


def run_virtual(main: Callable[[], Coroutine[Any, Any, T]]) -> T:
    """Run ``main()`` on a fresh virtual-time loop."""
    loop = VirtualTimeLoop()
    try:
        return loop.run_until_complete(main())
    finally:
        loop.close()


def ramp(per_second: float) -> Callable[[float], float]:
    return lambda t: 10.0 + (t - START) * per_second


def make_module(
    module_id: str,
    seed: int,
    baud: int = 9600,
    humidity: bool = False,
    signal: Callable[[float], float] | None = None,
    now: float = START,
) -> Hctmps1Module:
    variant = HUM if humidity else TEMP
    config = ModuleConfig(module_id, variant, slot=slot_time(baud))
    return Hctmps1Module(
        config, signal or (lambda t: 21.5), MemoryEeprom(), random.Random(seed), now
    )


async def start_bus(core: BusCore) -> DeviceHost:
    """Serve ``core`` with the runtime on the loop's clock (started at START)."""
    host = DeviceHost(core, LoopClock(START))
    host.start()
    return host


class ServedBus:
    """A real ``sondalog bus serve`` subprocess; ``port`` is read from its first line."""

    def __init__(self, state: Path, *args: str) -> None:
        self.log_path = state.parent / f"{state.name}-serve.log"
        self._log = self.log_path.open("ab")
        command = [sys.executable, "-m", "sondalog", "bus", "serve", "--listen", "127.0.0.1:0"]
        self.proc = subprocess.Popen(
            [*command, "--state", str(state), *args],
            stdout=subprocess.PIPE,
            stderr=self._log,
        )
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], 20)
        line = self.proc.stdout.readline().decode() if ready else ""
        if not line.startswith("listening on 127.0.0.1:"):
            self.kill()
            raise RuntimeError(f"bus serve did not start: {line!r} {self.log_path.read_text()}")
        self.port = int(line.rsplit(":", 1)[1])
        self.url = f"tcp://127.0.0.1:{self.port}"

    def terminate(self) -> int:
        self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=10)
        finally:
            self.kill()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._log.close()

    def __enter__(self) -> ServedBus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.kill()


def sondalog(*args: str, timeout: float = 30) -> subprocess.CompletedProcess[str]:
    """Run the real CLI."""
    return subprocess.run(
        [sys.executable, "-m", "sondalog", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
