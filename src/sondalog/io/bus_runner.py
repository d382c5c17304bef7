"""Run a :class:`~sondalog.world.bus.BusCore` on a clock, with asyncio ports (DESIGN.md 1, 2).

:class:`VirtualBus` is the thin asyncio adapter: it sleeps on the clock until the core's next
deadline or until a port writes, runs the core up to the clock's time and hands received bytes
to the ports. A :class:`BusPort` is what a transport (TCP connection, pty, serial line, or an
in-process host) holds: :meth:`BusPort.write` to transmit, a callback or :meth:`BusPort.receive`
to receive. A port is also a :class:`sondalog.client.bus.BusLink` for an in-process host.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from typing import Any

from sondalog.io.clock import Clock
from sondalog.world.bus import BusCore

log = logging.getLogger(__name__)


class LoopClock:
    """Clock seconds that follow the event loop's own time.

    Starts at the wall clock and then runs with ``loop.time()``. In production that is the
    monotonic clock; a test running a virtual-time event loop gets a bus that runs in virtual
    time, with the host's asyncio timeouts on the same time base.
    """

    def __init__(self, start: float | None = None) -> None:
        self._loop = asyncio.get_running_loop()
        self._offset = (time.time() if start is None else start) - self._loop.time()

    def now(self) -> float:
        return self._loop.time() + self._offset

    async def sleep_until(self, deadline: float) -> None:
        delay = deadline - self.now()
        if delay > 0:
            await asyncio.sleep(delay)


class BusPort:
    """A host's attachment to the bus."""

    def __init__(self, bus: VirtualBus, node: int) -> None:
        self.bus = bus
        self.node = node
        self.on_data: Callable[[bytes], None] | None = None
        self._queue: asyncio.Queue[bytes] = asyncio.Queue()
        self.closed = False

    def write(self, data: bytes) -> None:
        """Transmit ``data`` on the bus now."""
        if not self.closed:
            self.bus.write(self, data)

    def deliver(self, data: bytes) -> None:
        if self.closed:
            return
        if self.on_data is not None:
            self.on_data(data)
        else:
            self._queue.put_nowait(data)

    def detach(self) -> None:
        """Leave the bus."""
        if not self.closed:
            self.closed = True
            self.bus.detach(self)
            self._queue.put_nowait(b"")

    # The BusLink interface of sondalog.client.bus, for a host in the same process.

    async def send(self, data: bytes) -> None:
        self.write(data)

    async def receive(self) -> bytes:
        """The next received bytes (when no ``on_data`` callback is set); b"" once detached."""
        if self.closed and self._queue.empty():
            return b""
        return await self._queue.get()

    async def close(self) -> None:
        self.detach()


class VirtualBus:
    """The asyncio driver of a :class:`BusCore`."""

    def __init__(self, core: BusCore, clock: Clock) -> None:
        self.core = core
        self.clock = clock
        self._ports: dict[int, BusPort] = {}
        self._wake = asyncio.Event()

    def open_port(self) -> BusPort:
        port = BusPort(self, self.core.add_port())
        self._ports[port.node] = port
        return port

    def detach(self, port: BusPort) -> None:
        self._ports.pop(port.node, None)
        self.core.remove_port(port.node)

    def write(self, port: BusPort, data: bytes) -> None:
        self._dispatch(self.core.write(port.node, data, self.clock.now()))
        self._wake.set()

    def _dispatch(self, received: dict[int, bytes]) -> None:
        for node, data in received.items():
            port = self._ports.get(node)
            if port is not None:
                try:
                    port.deliver(data)
                except Exception:  # a broken transport must not stop the bus
                    log.exception("bus port %s failed to take %r", node, data)

    async def run(self) -> None:
        """Run the bus until cancelled."""
        while True:
            self._dispatch(self.core.advance(self.clock.now()))
            await self._wait(self.core.next_deadline())

    async def _wait(self, deadline: float | None) -> None:
        if self._wake.is_set():
            self._wake.clear()
            return
        waker = asyncio.ensure_future(self._wake.wait())
        tasks: set[asyncio.Future[Any]] = {waker}
        if deadline is not None:
            tasks.add(asyncio.ensure_future(self.clock.sleep_until(deadline)))
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        self._wake.clear()
