"""GPIO chips without a gpiochip, behind the same :class:`~sondalog.backends.linux.gpio.
GpioChip` interface as the real one.

:class:`FakeChip` lives in memory and tests drive it: edge events are injected with
timestamps in the chip's own nanosecond clock (:attr:`FakeChip.now_ns`); the chip wakes its
reader through a real pipe, so the backend's ``loop.add_reader`` path runs exactly as on a
board.

:class:`DirChip` is a directory standing for ``/dev/gpiochipN`` in a fake tree
(``SONDALOG_ROOT``), so a user exercises outputs and pulse counting without a board
(docs/linux-board.md, "Testing without a board"): an output line is the file ``lineN``
holding ``1`` (active) or ``0``; a pulse input line is the named pipe ``lineN``, and each
line written to it is that many edges now (an empty line: one).
"""

from __future__ import annotations

import contextlib
import logging
import os
import stat
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from sondalog.backends.linux.gpio import BiasKind, Edge, EdgeKind, EdgeLines, OutputLines

log = logging.getLogger(__name__)
#: Most edges one line written to a :class:`DirChip` pipe may ask for.
MAX_WRITTEN = 100_000


def _offset_of(line: int | str, lines: int) -> int:
    """``17`` or ``"GPIO17"`` (the Raspberry Pi's line names) on a chip of ``lines`` lines."""
    offset = line
    if isinstance(line, str):
        offset = int(line[4:]) if line.startswith("GPIO") and line[4:].isdigit() else -1
    if not isinstance(offset, int) or not 0 <= offset < lines:
        raise ValueError(f"no line {line!r} on the fake chip (0..{lines - 1} or GPIO0..)")
    return offset


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
        return _offset_of(line, self.lines)

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


class DirChip:
    """A directory as a chip: output lines are files, pulse input lines named pipes."""

    def __init__(self, path: Path, lines: int = 54) -> None:
        if not path.is_dir():
            raise OSError(2, f"{path} is not a directory")
        self.path = path
        self.lines = lines
        self._busy: set[int] = set()

    def offset_of(self, line: int | str) -> int:
        return _offset_of(line, self.lines)

    def _claim(self, offsets: Sequence[int]) -> None:
        for offset in offsets:
            if offset in self._busy:
                raise OSError(16, f"line {offset} is busy")
        self._busy.update(offsets)

    def request_outputs(self, lines: Mapping[int, bool], consumer: str) -> OutputLines:
        self._claim(list(lines))
        outputs = _DirOutputs(self)
        for offset in lines:
            outputs.set(offset, False)
        return outputs

    def request_edges(
        self,
        offsets: Sequence[int],
        consumer: str,
        *,
        edge: EdgeKind,
        bias: BiasKind,
        debounce: float,
    ) -> EdgeLines:
        if len(offsets) != 1:
            raise ValueError("a directory chip takes one pulse line per request")
        self._claim(offsets)
        return _DirEdges(self.path / f"line{offsets[0]}", offsets[0], edge)

    def close(self) -> None:
        self._busy.clear()


class _DirOutputs:
    def __init__(self, chip: DirChip) -> None:
        self.chip = chip

    def set(self, offset: int, on: bool) -> None:
        (self.chip.path / f"line{offset}").write_text("1\n" if on else "0\n", encoding="ascii")
        log.info("%s line %d: %s", self.chip.path, offset, "active" if on else "inactive")

    def release(self) -> None:
        return None


class _DirEdges:
    """A named pipe ``lineN``, opened read-write so that it never reads as closed."""

    def __init__(self, path: Path, offset: int, edge: EdgeKind) -> None:
        with contextlib.suppress(FileNotFoundError):
            if not stat.S_ISFIFO(path.lstat().st_mode):
                path.unlink()  # a file left by `echo` while nothing was serving
        if not path.exists():
            os.mkfifo(path, 0o660)
        self.path = path
        self.offset = offset
        self.edge = edge
        self.fd = os.open(path, os.O_RDWR | os.O_NONBLOCK)
        self._partial = b""
        self._rising = edge == "rising"

    def fileno(self) -> int:
        return self.fd

    def read(self) -> list[Edge]:
        data = b""
        with contextlib.suppress(BlockingIOError):
            while chunk := os.read(self.fd, 4096):
                data += chunk
        *complete, self._partial = (self._partial + data).split(b"\n")
        now = time.monotonic_ns()
        edges: list[Edge] = []
        for raw in complete:
            text = raw.decode("ascii", "replace").strip()
            count = int(text) if text.isdigit() else 1 if not text else -1
            if not 0 <= count <= MAX_WRITTEN:
                log.warning(
                    "%s: %r is not a number of pulses (0..%d)", self.path, text, MAX_WRITTEN
                )
                continue
            for _ in range(count):
                if self.edge == "both":
                    self._rising = not self._rising
                edges.append(Edge(self.offset, now, self._rising))
        return edges

    def clock_ns(self) -> int:
        return time.monotonic_ns()

    def release(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
            with contextlib.suppress(OSError):
                self.path.unlink()  # a writer would otherwise wait for a reader forever
