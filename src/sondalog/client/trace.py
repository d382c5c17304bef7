"""Recording what a host tool and a logger say on the line: ``--trace FILE`` of the host tools.

:class:`TracedEndpoint` wraps any :class:`~sondalog.client.endpoints.Endpoint`: every byte the
client writes and every byte it receives is appended to a :class:`TraceWriter` in the line
trace format (:mod:`sondalog.protocol.line_trace`), which ``sondalog logger replay`` serves
back (docs/testing.md "Replay")::

    client = await Ala1Client.connect(TracedEndpoint(parse_url(url), TraceWriter(path)))

The file is private (0600, docs/security.md: a session may carry passwords) and flushed
after each chunk, so a trace survives a crash of the tool.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO, TypeVar

from sondalog.client.endpoints import Endpoint
from sondalog.io.private import open_private
from sondalog.protocol.line_trace import HEADER, trace_line

_P = TypeVar("_P", bound=asyncio.Protocol)


class TraceWriter:
    """A trace file being written (truncated when opened)."""

    def __init__(self, path: Path | str, peer: str = "") -> None:
        self.path = Path(path)
        self._file: TextIO | None = open_private(self.path, "w")
        self._file.write(f"{HEADER}: {peer}\n" if peer else f"{HEADER}\n")
        self._file.flush()

    def record(self, to_device: bool, data: bytes) -> None:
        if self._file is not None and data:
            self._file.write(trace_line(to_device, data, time.time()))
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


class _TracedTransport(asyncio.Transport):
    """The real transport, with what is written recorded first."""

    def __init__(self, inner: asyncio.Transport, writer: TraceWriter) -> None:
        super().__init__()
        self._inner = inner
        self._writer = writer

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self._writer.record(True, bytes(data))
        self._inner.write(data)

    def close(self) -> None:
        self._inner.close()

    def is_closing(self) -> bool:
        return self._inner.is_closing()

    def abort(self) -> None:
        self._inner.abort()

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return self._inner.get_extra_info(name, default)

    def pause_reading(self) -> None:
        self._inner.pause_reading()

    def resume_reading(self) -> None:
        self._inner.resume_reading()

    def is_reading(self) -> bool:
        return self._inner.is_reading()

    def can_write_eof(self) -> bool:
        return self._inner.can_write_eof()

    def write_eof(self) -> None:
        self._inner.write_eof()

    def get_write_buffer_size(self) -> int:
        return self._inner.get_write_buffer_size()


class _TracedProtocol(asyncio.Protocol):
    """The client's protocol, with what arrives recorded first."""

    def __init__(self, inner: asyncio.Protocol, writer: TraceWriter) -> None:
        self.inner = inner
        self._writer = writer

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.inner.connection_made(_TracedTransport(transport, self._writer))

    def data_received(self, data: bytes) -> None:
        self._writer.record(False, data)
        self.inner.data_received(data)

    def connection_lost(self, exc: Exception | None) -> None:
        self.inner.connection_lost(exc)

    def pause_writing(self) -> None:
        self.inner.pause_writing()

    def resume_writing(self) -> None:
        self.inner.resume_writing()


@dataclass(frozen=True)
class TracedEndpoint:
    """``endpoint``, with the connection's bytes both ways recorded by ``writer``."""

    endpoint: Endpoint
    writer: TraceWriter

    async def connect(self, factory: Callable[[], _P]) -> tuple[asyncio.BaseTransport, _P]:
        made: list[_P] = []

        def traced() -> _TracedProtocol:
            made.append(factory())
            return _TracedProtocol(made[0], self.writer)

        transport, _ = await self.endpoint.connect(traced)
        return transport, made[0]

    def __str__(self) -> str:
        return str(self.endpoint)
