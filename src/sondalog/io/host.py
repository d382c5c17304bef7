"""The one runtime: drive any pure device core from asyncio (DESIGN.md points 1, 2 and 6).

A :class:`DeviceHost` owns a :class:`~sondalog.protocol.device.Device` (the ALA1 engine, the
RS-485 bus with its modules, ...) and a :class:`~sondalog.io.clock.Clock`. It passes
``clock.now()`` with every call, routes each :class:`~sondalog.protocol.device.LineSend` to
the sink of its line and every other effect to the handler registered for its type, and keeps
its device's :meth:`Device.next_deadline` in the one deadline loop (:mod:`sondalog.io.timers`,
its own or a fleet's shared one), which calls :meth:`Device.advance` when it comes. The
deadline is updated whenever input changes it.

Transports (:mod:`sondalog.io.tcp`, :mod:`~sondalog.io.pty`, :mod:`~sondalog.io.serial_line`,
an in-process :class:`LocalLink`) attach lines to a host. Input is served fairly: one command
line per line and turn of the event loop, round-robin (issue 9). A device that bounds what a
line holds (the ALA1 while a command waits in ``pause``: ``input_room``, issue 20) is fed no
more than that on a line whose transport can be paused (TCP): the input waits here and the
transport stops being read. Other lines (a serial port has no input flow control, §6.11.1)
are fed, and the device drops what it cannot hold.

No protocol logic lives here: bytes in, bytes out. An internal exception is logged with the
offending bytes and the loop carries on (DESIGN.md point 6).
"""

from __future__ import annotations

import asyncio
import collections
import logging
import re
from collections.abc import Callable, Sequence
from typing import Protocol

from sondalog.io.clock import Clock
from sondalog.io.timers import Timers
from sondalog.protocol.device import Device, Effect, Event, LineSend

log = logging.getLogger(__name__)

#: Where the bytes for one line go (e.g. ``transport.write`` of a TCP connection).
Sink = Callable[[bytes], None]
#: Where the outputs of one line go when the rate they were paced at matters (serial ports).
OutputSink = Callable[[LineSend], None]
#: What takes the effects of one type that are not line bytes (messages, modem, mail...).
EffectHandler = Callable[[Effect], None]
#: A line's input beyond this many unprocessed bytes pauses its transport; below LOW resumes.
PENDING_HIGH = 64 * 1024
PENDING_LOW = 16 * 1024
#: The most bytes of one line run per turn when no line end comes sooner.
SLICE = 512
#: How many bytes a device's line takes now without losing any (None: no bound); optional.
InputRoom = Callable[[int], int | None]


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


#: One line: no line end (CR or LF) but the last byte.
_ONE_LINE = re.compile(rb"[^\r\n]*[\r\n]")


class DeviceHost:
    """One device core, its clock, its timers, and the sinks of its attached lines."""

    def __init__(self, device: Device, clock: Clock, timers: Timers | None = None) -> None:
        """``timers``: the deadline loop shared with other hosts (a fleet's, issue 24);
        without it the host has one of its own."""
        self.device = device
        self.clock = clock
        self._handlers: dict[type[Effect], EffectHandler] = {}
        # Every attached line has one sink: bytes only (transports), or each LineSend.
        self._byte_sinks: dict[int, Sink] = {}
        self._output_sinks: dict[int, OutputSink] = {}
        self._timers = timers if timers is not None else Timers(clock)
        self._started = False
        self._pending: dict[int, bytearray] = {}  # line -> input not yet run
        self._ready: collections.deque[int] = collections.deque()  # lines with input, in turn
        self._flows: dict[int, FlowControl] = {}
        self._pump_scheduled = False
        self._room: InputRoom | None = getattr(device, "input_room", None)
        self._held: set[int] = set()  # lines with input the device cannot take now

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        """Run the device at its deadlines from now on (needs a running event loop)."""
        if not self._started:
            self._started = True
            self._timers.add(self, self._next_deadline())

    async def stop(self) -> None:
        """Stop running the device at its deadlines and detach every line."""
        if self._started:
            self._started = False
            await self._timers.remove(self)
        for line_id in [*self._byte_sinks, *self._output_sinks]:
            self.detach(line_id)

    def replace_device(self, device: Device) -> None:
        """Serve ``device`` from now on, on the same lines (the control API's hook: a logger
        behind its line faults, or restarted after a power loss, issue 23)."""
        self.device = device
        self._room = getattr(device, "input_room", None)
        self.wake()

    def wake(self) -> None:
        """The device changed from outside (its clock jumped): look at its deadline again."""
        self._check_deadline()
        self._timers.wake()

    # -- lines -------------------------------------------------------------------------------
    def attach(self, sink: Sink, *, paced: bool = False, flow: FlowControl | None = None) -> int:
        """A new connection: opens an engine line whose output goes to ``sink``.

        ``paced``: the engine releases the output at ``com speed`` (serial and pty lines, TCP
        with ``--line-rate``); the sink just writes what it gets.
        """
        line_id = self._open(paced, flow)
        self._byte_sinks[line_id] = sink
        return line_id

    def attach_output(
        self, sink: OutputSink, *, paced: bool = False, flow: FlowControl | None = None
    ) -> int:
        """Like :meth:`attach`, for a sink that needs each :class:`Output`'s baud rate.

        ``flow``: the transport to pause while this line's unprocessed input piles up."""
        line_id = self._open(paced, flow)
        self._output_sinks[line_id] = sink
        return line_id

    def _open(self, paced: bool, flow: FlowControl | None) -> int:
        line_id = self.device.open_line(paced=paced)
        if flow is not None:
            self._flows[line_id] = flow
        return line_id

    def _attached(self, line_id: int) -> bool:
        return line_id in self._byte_sinks or line_id in self._output_sinks

    def adopt(self, line_id: int, sink: OutputSink) -> None:
        """Route a line the device opened itself (the ALA1's modem line) to ``sink``."""
        self._output_sinks[line_id] = sink

    def detach(self, line_id: int) -> None:
        """The connection is gone: its partial command and pending output are dropped."""
        self._byte_sinks.pop(line_id, None)
        self._output_sinks.pop(line_id, None)
        self._pending.pop(line_id, None)
        self._held.discard(line_id)
        self._flows.pop(line_id, None)
        try:
            self.device.close_line(line_id)
        except Exception:
            log.exception("internal error closing line %d", line_id)
        self._check_deadline()

    def feed(self, line_id: int, data: bytes) -> None:
        """Bytes received on a line: queued, then run through the engine one command line
        per line and turn of the event loop, round-robin (issue 9: fair service)."""
        if not self._attached(line_id):
            return
        pending = self._pending.get(line_id)
        if (
            pending is None
            and line_id in self._flows
            and len(data) <= SLICE
            and _ONE_LINE.fullmatch(data) is not None
            and self._takes(line_id, len(data))
        ):
            # Fast path (issue 11): a transport's one whole command line while that line
            # has nothing queued is its slice of this turn: run it now, as the pump would.
            self._receive(line_id, data)
            self._check_deadline()
            return
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
            room = self._room(line_id) if self._room and line_id in self._flows else None
            if room is not None and room < cut:
                if room <= 0:  # it waits until the device takes input again (_wake_held)
                    self._held.add(line_id)
                    continue
                cut = room
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

    def _takes(self, line_id: int, size: int) -> bool:
        """The device takes ``size`` bytes on the line now without losing any."""
        if self._room is None:
            return True
        room = self._room(line_id)
        return room is None or room >= size

    def _wake_held(self) -> None:
        """Lines whose input waited for the device (a ``pause`` ended) take their turn."""
        woken = [line_id for line_id in self._held if self._takes(line_id, 1)]
        if not woken:
            return
        for line_id in woken:
            self._held.discard(line_id)
            self._ready.append(line_id)
        if not self._pump_scheduled:
            self._pump_scheduled = True
            asyncio.get_running_loop().call_soon(self._pump)

    def deliver(self, line_id: int, data: bytes) -> None:
        """Bytes from a device's own peer (the ALA1's modem) run at once and whole: they are
        not a person's command lines to share out fairly, and their result codes must not be
        cut apart (``\r\nSHUTDOWN\r\n``)."""
        if self._attached(line_id):
            self._receive(line_id, data)
            self._check_deadline()

    def _receive(self, line_id: int, data: bytes) -> None:
        try:
            outputs = self.device.receive(line_id, data, self.clock.now())
        except Exception:
            log.exception("internal error on line %d receiving %r", line_id, data)
            outputs = []
        self._dispatch(outputs)

    # -- internals ---------------------------------------------------------------------------
    def on_effect(self, kind: type[Effect], handler: EffectHandler) -> None:
        """Route effects of type ``kind`` (other than line bytes) to ``handler``."""
        self._handlers[kind] = handler

    def post(self, event: Event) -> None:
        """A typed event for the device (an SMS arrived, a call, ...), at the clock's now."""
        try:
            effects = self.device.handle(event, self.clock.now())
        except Exception:
            log.exception("internal error handling %r", event)
            effects = []
        self._dispatch(effects)
        self._check_deadline()

    def link(self, on_data: Sink | None = None, *, paced: bool = False) -> LocalLink:
        """An in-process line (a bus master or a client in the same process); received
        bytes go to ``on_data`` when given, else to :meth:`LocalLink.receive`."""
        return LocalLink(self, on_data, paced=paced)

    def _dispatch(self, effects: Sequence[Effect]) -> None:
        for output in effects:
            if not isinstance(output, LineSend):
                handler = self._handlers.get(type(output))
                if handler is None:
                    log.warning("no handler for %r", output)
                    continue
                try:
                    handler(output)
                except Exception:
                    log.exception("handler of %r failed", output)
                continue
            try:
                byte_sink = self._byte_sinks.get(output.line)
                if byte_sink is not None:
                    byte_sink(output.data)
                elif (sink := self._output_sinks.get(output.line)) is not None:
                    sink(output)
                # (else the line went away while its answer was pending)
            except Exception:
                log.exception("cannot send %r to line %d", output.data, output.line)

    def _check_deadline(self) -> None:
        """Tell the timers when the device's next deadline moved."""
        if self._held:
            self._wake_held()
        if self._started:
            self._timers.set(self, self._next_deadline())

    def _next_deadline(self) -> float | None:
        try:
            return self.device.next_deadline()
        except Exception:
            log.exception("internal error computing the next deadline")
            return self.clock.now() + 1.0  # try again in a while, never spin

    def run_due(self, now: float) -> None:
        """The deadline came (the timers call this): run what is due at ``now``."""
        try:
            outputs = self.device.advance(now)
        except Exception:
            log.exception("internal error running timers at %r", now)
            self._timers.set(self, now + 1.0)  # never spin on a timer that keeps failing
            return
        self._dispatch(outputs)
        self._check_deadline()


class LocalLink:
    """A line of a :class:`DeviceHost` for a peer in the same process.

    It has the byte-link interface of :mod:`sondalog.client` (``send``, ``receive``,
    ``close``), so a bus master or an ALA1 client can talk to a device without a socket."""

    def __init__(
        self, host: DeviceHost, on_data: Sink | None = None, *, paced: bool = False
    ) -> None:
        self._host = host
        self._queue: asyncio.Queue[bytes] = asyncio.Queue()
        self.closed = False
        self.line = host.attach(on_data or self._queue.put_nowait, paced=paced)

    def write(self, data: bytes) -> None:
        """Send ``data`` on the line now."""
        if not self.closed:
            self._host.feed(self.line, data)

    async def send(self, data: bytes) -> None:
        self.write(data)

    async def receive(self) -> bytes:
        """The next bytes received; b"" once closed."""
        if self.closed and self._queue.empty():
            return b""
        return await self._queue.get()

    async def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._host.detach(self.line)
            self._queue.put_nowait(b"")
