"""GPIO lines through libgpiod v2: outputs powering sensors and pulse inputs (§6.5.13, §6.7).

The backend talks to a :class:`GpioChip`; :class:`GpiodChip` is the real one (the PyPI
``gpiod`` 2.x package over ``/dev/gpiochipN``), :class:`~sondalog.backends.linux.fakegpio.
FakeChip` the one tests drive. Pulse inputs are counted from *edge events* with kernel
timestamps: :class:`PulseCounter` keeps each line's event times (converted to the host
clock) and counts the events in a window ``[t0, t1)`` exactly, however late the asyncio loop
reads them.
"""

from __future__ import annotations

import bisect
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import timedelta
from typing import TYPE_CHECKING, Literal, Protocol

if TYPE_CHECKING:
    import gpiod

EdgeKind = Literal["rising", "falling", "both"]
BiasKind = Literal["as-is", "pull-up", "pull-down", "disabled"]
#: Pulses older than this are forgotten (the longest counting window the core asks for is a
#: channel's sampling period; sondalog decision: at most one day on a Linux board).
RETENTION = 86_400.0
#: At most this many remembered pulses per line (a 10 Hz input over a day).
MAX_EVENTS = 1_000_000


@dataclass(frozen=True, slots=True)
class Edge:
    """One edge event: line offset, kernel timestamp (the chip's clock, ns), direction."""

    offset: int
    timestamp_ns: int
    rising: bool


class OutputLines(Protocol):
    """Requested output lines."""

    def set(self, offset: int, on: bool) -> None: ...

    def release(self) -> None: ...


class EdgeLines(Protocol):
    """Requested input lines with edge detection; ``fileno`` is readable when events wait."""

    def fileno(self) -> int: ...

    def read(self) -> list[Edge]: ...

    def clock_ns(self) -> int:
        """The clock the event timestamps are in, now."""
        ...

    def release(self) -> None: ...


class GpioChip(Protocol):
    """What the backend needs of a GPIO chip."""

    def offset_of(self, line: int | str) -> int: ...

    def request_outputs(self, lines: Mapping[int, bool], consumer: str) -> OutputLines:
        """Outputs, initially inactive; ``lines`` maps offset -> active-low."""
        ...

    def request_edges(
        self,
        offsets: Sequence[int],
        consumer: str,
        *,
        edge: EdgeKind,
        bias: BiasKind,
        debounce: float,
    ) -> EdgeLines: ...

    def close(self) -> None: ...


class GpiodChip:
    """A real chip through the ``gpiod`` 2.x bindings (``/dev/gpiochipN``)."""

    def __init__(self, path: str) -> None:
        import gpiod  # imported here: only a real board needs the bindings

        self.path = path
        self._chip = gpiod.Chip(path)

    def offset_of(self, line: int | str) -> int:
        return self._chip.line_offset_from_id(line)

    def request_outputs(self, lines: Mapping[int, bool], consumer: str) -> OutputLines:
        import gpiod
        from gpiod.line import Direction, Value

        config: dict[Iterable[int | str] | int | str, gpiod.LineSettings | None] = {
            offset: gpiod.LineSettings(
                direction=Direction.OUTPUT, active_low=low, output_value=Value.INACTIVE
            )
            for offset, low in lines.items()
        }
        return _GpiodOutputs(self._chip.request_lines(config, consumer=consumer))

    def request_edges(
        self,
        offsets: Sequence[int],
        consumer: str,
        *,
        edge: EdgeKind,
        bias: BiasKind,
        debounce: float,
    ) -> EdgeLines:
        import gpiod
        from gpiod.line import Bias, Clock, Direction
        from gpiod.line import Edge as GEdge

        settings = gpiod.LineSettings(
            direction=Direction.INPUT,
            edge_detection={"rising": GEdge.RISING, "falling": GEdge.FALLING}.get(edge, GEdge.BOTH),
            bias={
                "pull-up": Bias.PULL_UP,
                "pull-down": Bias.PULL_DOWN,
                "disabled": Bias.DISABLED,
            }.get(bias, Bias.AS_IS),
            debounce_period=timedelta(seconds=debounce),
            event_clock=Clock.MONOTONIC,
        )
        config: dict[Iterable[int | str] | int | str, gpiod.LineSettings | None] = {
            tuple(offsets): settings
        }
        return _GpiodEdges(self._chip.request_lines(config, consumer=consumer))

    def close(self) -> None:
        self._chip.close()


class _GpiodOutputs:
    def __init__(self, request: gpiod.LineRequest) -> None:
        self._request = request

    def set(self, offset: int, on: bool) -> None:
        from gpiod.line import Value

        self._request.set_value(offset, Value.ACTIVE if on else Value.INACTIVE)

    def release(self) -> None:
        self._request.release()


class _GpiodEdges:
    def __init__(self, request: gpiod.LineRequest) -> None:
        self._request = request

    def fileno(self) -> int:
        return self._request.fd

    def read(self) -> list[Edge]:
        from gpiod.edge_event import EdgeEvent

        events: list[EdgeEvent] = self._request.read_edge_events()
        return [
            Edge(e.line_offset, e.timestamp_ns, e.event_type is EdgeEvent.Type.RISING_EDGE)
            for e in events
        ]

    def clock_ns(self) -> int:
        return time.monotonic_ns()  # the kernel's CLOCK_MONOTONIC, as requested

    def release(self) -> None:
        self._request.release()


class PulseCounter:
    """Edge events of pulse inputs as host-clock times; counts in half-open windows."""

    def __init__(self, host_now: Callable[[], float]) -> None:
        self.host_now = host_now
        self._times: dict[int, list[float]] = {}

    def watch(self, offset: int) -> None:
        self._times.setdefault(offset, [])

    def take(self, edges: Sequence[Edge], clock_ns: int) -> None:
        """Record edges read now; ``clock_ns`` is the events' clock at the moment of reading
        (so ``host = host_now - (clock_ns - timestamp) / 1e9``)."""
        now = self.host_now()
        for edge in edges:
            times = self._times.get(edge.offset)
            if times is None:
                continue
            t = now - (clock_ns - edge.timestamp_ns) / 1e9
            if times and t < times[-1]:
                bisect.insort(times, t)
            else:
                times.append(t)
        horizon = now - RETENTION
        for times in self._times.values():
            drop = max(bisect.bisect_left(times, horizon), len(times) - MAX_EVENTS)
            if drop > 0:
                del times[:drop]

    def count(self, offset: int, t0: float, t1: float) -> int:
        """Pulses on line ``offset`` with ``t0 <= time < t1``."""
        times = self._times.get(offset, [])
        return max(0, bisect.bisect_left(times, t1) - bisect.bisect_left(times, t0))
