"""A GPIO chip in memory, behind the same :class:`~sondalog.backends.linux.gpio.GpioChip`
interface as the real one: tests (and dry runs of a board file) drive it.

Edge events are injected with timestamps in the chip's own nanosecond clock
(:attr:`FakeChip.now_ns`); the chip wakes its reader through a real pipe, so the backend's
``loop.add_reader`` path runs exactly as on a board.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Mapping, Sequence

from sondalog.backends.linux.gpio import BiasKind, Edge, EdgeKind, EdgeLines, OutputLines


class FakeChip:
    """A chip with ``lines`` named lines (``GPIO0`` ..) whose outputs and edges tests see."""

    def __init__(self, lines: int = 54, clock: Callable[[], float] | None = None) -> None:
        self.lines = lines
        self.clock = clock  # the chip's clock in seconds (default: ``now_ns`` as set)
        self._now_ns = 1_000_000_000
        self.levels: dict[int, bool] = {}  # output offset -> active
        self.history: list[tuple[int, bool]] = []  # every output change, in order
        self.edge_settings: dict[int, tuple[EdgeKind, BiasKind, float]] = {}
        self._requests: list[_FakeEdges] = []

    @property
    def now_ns(self) -> int:
        """The chip's event clock now, in nanoseconds."""
        return round(self.clock() * 1e9) if self.clock is not None else self._now_ns

    @now_ns.setter
    def now_ns(self, value: int) -> None:
        self._now_ns = value

    def offset_of(self, line: int | str) -> int:
        offset = int(line[4:]) if isinstance(line, str) and line.startswith("GPIO") else line
        if not isinstance(offset, int) or not 0 <= offset < self.lines:
            raise ValueError(f"no line {line!r} on the fake chip")
        return offset

    def request_outputs(self, lines: Mapping[int, bool], consumer: str) -> OutputLines:
        for offset in lines:
            if offset in self.levels or offset in self.edge_settings:
                raise OSError(16, f"line {offset} is busy")
            self.levels[offset] = False
        return _FakeOutputs(self)

    def request_edges(
        self,
        offsets: Sequence[int],
        consumer: str,
        *,
        edge: EdgeKind,
        bias: BiasKind,
        debounce: float,
    ) -> EdgeLines:
        for offset in offsets:
            if offset in self.levels or offset in self.edge_settings:
                raise OSError(16, f"line {offset} is busy")
            self.edge_settings[offset] = (edge, bias, debounce)
        request = _FakeEdges(self, offsets)
        self._requests.append(request)
        return request

    def inject(self, offset: int, timestamp_ns: int, rising: bool = True) -> None:
        """An edge on ``offset`` at ``timestamp_ns`` (the chip's clock)."""
        for request in self._requests:
            if offset in request.offsets:
                request.pending.append(Edge(offset, timestamp_ns, rising))
                os.write(request.write_fd, b"!")

    def pulse_at(self, offset: int, seconds: float, rising: bool = False) -> None:
        """An edge at ``seconds`` of the chip's clock (see ``clock``)."""
        self.inject(offset, round(seconds * 1e9), rising)

    def close(self) -> None:
        for request in self._requests:
            request.release()
        self._requests.clear()


class _FakeOutputs:
    def __init__(self, chip: FakeChip) -> None:
        self.chip = chip

    def set(self, offset: int, on: bool) -> None:
        self.chip.levels[offset] = on
        self.chip.history.append((offset, on))

    def release(self) -> None:
        return None


class _FakeEdges:
    """One edge request: its own pipe stands for the kernel request's fd."""

    def __init__(self, chip: FakeChip, offsets: Sequence[int]) -> None:
        self.chip = chip
        self.offsets = set(offsets)
        self.pending: list[Edge] = []
        self.read_fd, self.write_fd = os.pipe()
        os.set_blocking(self.read_fd, False)

    def fileno(self) -> int:
        return self.read_fd

    def read(self) -> list[Edge]:
        with contextlib.suppress(BlockingIOError):
            os.read(self.read_fd, 4096)
        edges, self.pending = self.pending, []
        return [e for e in edges if self._wanted(e)]

    def _wanted(self, edge: Edge) -> bool:
        kind = self.chip.edge_settings.get(edge.offset, ("both", "as-is", 0.0))[0]
        return kind == "both" or (kind == "rising") == edge.rising

    def clock_ns(self) -> int:
        return self.chip.now_ns

    def release(self) -> None:
        if self.read_fd >= 0:
            os.close(self.read_fd)
            os.close(self.write_fd)
            self.read_fd = self.write_fd = -1
