"""Drive one pure ALA1 engine from asyncio (DESIGN.md points 1, 2 and 6).

The host owns the :class:`~sondalog.ala1.Engine` and a :class:`~sondalog.io.clock.Clock`. It
passes ``clock.now()`` with every call, routes each :class:`~sondalog.ala1.Output` to the sink
of its line, and runs a timer task that sleeps until :meth:`Engine.next_deadline` and then
calls :meth:`Engine.advance` (``pause`` headers, §8.5.1; the 60 s entry timeout, §3.4.5). The
timer is re-armed whenever input changes the engine's next deadline.

No protocol logic lives here: bytes in, bytes out. An internal exception is logged with the
offending bytes and the loop carries on (DESIGN.md point 6).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import logging
from collections.abc import Callable
from typing import Protocol

from sondalog.ala1 import Engine, Output
from sondalog.io.clock import Clock

log = logging.getLogger(__name__)

#: Where the bytes for one line go (e.g. ``transport.write`` of a TCP connection).
Sink = Callable[[bytes], None]
#: Where the outputs of one line go when the rate they were paced at matters (serial ports).
OutputSink = Callable[[Output], None]
#: A line's input beyond this many unprocessed bytes pauses its transport; below LOW resumes.
PENDING_HIGH = 64 * 1024
PENDING_LOW = 16 * 1024
#: The most bytes of one line run per turn when no line end comes sooner.
SLICE = 512


class FlowControl(Protocol):
    """What a transport offers to be paused while its line's input waits (asyncio's API)."""

    def pause_reading(self) -> None: ...

    def resume_reading(self) -> None: ...


def _slice_end(pending: bytearray) -> int:
    """End of the next slice: through the first CR or LF, at most :data:`SLICE` bytes."""
    window = min(len(pending), SLICE)
    cr = pending.find(b"\r", 0, window)
    lf = pending.find(b"\n", 0, window)
    ends = [i for i in (cr, lf) if i >= 0]
    return min(ends) + 1 if ends else window


class EngineHost:
    """One engine, its clock, its timers, and the sinks of its attached lines."""

    def __init__(self, engine: Engine, clock: Clock) -> None:
        self.engine = engine
        self.clock = clock
        self._sinks: dict[int, OutputSink] = {}
        self._armed: float | None = None
        self._rearm = asyncio.Event()
        self._timer: asyncio.Task[None] | None = None
        self._pending: dict[int, bytearray] = {}  # line -> input not yet run
        self._ready: collections.deque[int] = collections.deque()  # lines with input, in turn
        self._flows: dict[int, FlowControl] = {}
        self._pump_scheduled = False

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        """Start the timer task (needs a running event loop)."""
        if self._timer is None:
            self._timer = asyncio.get_running_loop().create_task(self._run_timers())

    async def stop(self) -> None:
        """Stop the timer task and detach every line."""
        if self._timer is not None:
            self._timer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._timer
            self._timer = None
        for line_id in list(self._sinks):
            self.detach(line_id)

    # -- lines -------------------------------------------------------------------------------
    def attach(self, sink: Sink, *, paced: bool = False, flow: FlowControl | None = None) -> int:
        """A new connection: opens an engine line whose output goes to ``sink``.

        ``paced``: the engine releases the output at ``com speed`` (serial and pty lines, TCP
        with ``--line-rate``); the sink just writes what it gets.
        """
        return self.attach_output(lambda output: sink(output.data), paced=paced, flow=flow)

    def attach_output(
        self, sink: OutputSink, *, paced: bool = False, flow: FlowControl | None = None
    ) -> int:
        """Like :meth:`attach`, for a sink that needs each :class:`Output`'s baud rate.

        ``flow``: the transport to pause while this line's unprocessed input piles up."""
        line_id = self.engine.open_line(paced=paced)
        self._sinks[line_id] = sink
        if flow is not None:
            self._flows[line_id] = flow
        return line_id

    def detach(self, line_id: int) -> None:
        """The connection is gone: its partial command and pending output are dropped."""
        self._sinks.pop(line_id, None)
        self._pending.pop(line_id, None)
        self._flows.pop(line_id, None)
        try:
            self.engine.close_line(line_id)
        except Exception:
            log.exception("internal error closing line %d", line_id)
        self._check_deadline()

    def feed(self, line_id: int, data: bytes) -> None:
        """Bytes received on a line: queued, then run through the engine one command line
        per line and turn of the event loop, round-robin (issue 9: fair service)."""
        if line_id not in self._sinks:
            return
        pending = self._pending.get(line_id)
        if pending is None:
            self._pending[line_id] = bytearray(data)
            self._ready.append(line_id)
        else:
            pending += data
        flow = self._flows.get(line_id)
        if flow is not None and len(self._pending[line_id]) > PENDING_HIGH:
            flow.pause_reading()
        if not self._pump_scheduled:
            self._pump_scheduled = True
            asyncio.get_running_loop().call_soon(self._pump)

    def _pump(self) -> None:
        """One round: one slice (up to and including a line end) of every line with input."""
        self._pump_scheduled = False
        for _ in range(len(self._ready)):
            line_id = self._ready.popleft()
            pending = self._pending.get(line_id)
            if pending is None:
                continue
            cut = _slice_end(pending)
            chunk = bytes(pending[:cut])
            del pending[:cut]
            if pending:
                self._ready.append(line_id)
            else:
                del self._pending[line_id]
            flow = self._flows.get(line_id)
            if flow is not None and len(pending) <= PENDING_LOW:
                flow.resume_reading()
            self._receive(line_id, chunk)
        self._check_deadline()
        if self._ready and not self._pump_scheduled:
            self._pump_scheduled = True
            asyncio.get_running_loop().call_soon(self._pump)

    def _receive(self, line_id: int, data: bytes) -> None:
        try:
            outputs = self.engine.receive(line_id, data, self.clock.now())
        except Exception:
            log.exception("internal error on line %d receiving %r", line_id, data)
            outputs = []
        self._dispatch(outputs)

    # -- internals ---------------------------------------------------------------------------
    def _dispatch(self, outputs: list[Output]) -> None:
        for output in outputs:
            sink = self._sinks.get(output.line)
            if sink is None:
                continue  # the line went away while its answer was pending
            try:
                sink(output)
            except Exception:
                log.exception("cannot send %r to line %d", output.data, output.line)

    def _check_deadline(self) -> None:
        """Wake the timer task when the engine's next deadline moved."""
        if self.engine.next_deadline() != self._armed:
            self._rearm.set()

    async def _run_timers(self) -> None:
        while True:
            self._rearm.clear()
            try:
                deadline = self.engine.next_deadline()
            except Exception:
                log.exception("internal error computing the next deadline")
                deadline = None
            self._armed = deadline
            if deadline is None:
                await self._rearm.wait()
                continue
            if self.clock.now() < deadline:
                await self._sleep_or_rearm(deadline)
            now = self.clock.now()
            if now >= deadline:
                try:
                    outputs = self.engine.advance(now)
                except Exception:
                    log.exception("internal error running timers at %r", now)
                    outputs = []
                    await asyncio.sleep(1.0)  # never spin on a timer that keeps failing
                self._dispatch(outputs)

    async def _sleep_or_rearm(self, deadline: float) -> None:
        sleeper = asyncio.ensure_future(self.clock.sleep_until(deadline))
        waker = asyncio.ensure_future(self._rearm.wait())
        try:
            await asyncio.wait({sleeper, waker}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in (sleeper, waker):
                task.cancel()
            await asyncio.gather(sleeper, waker, return_exceptions=True)
