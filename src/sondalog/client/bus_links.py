"""Links to an RS-485 bus for the bus master: URLs (``tcp://HOST:PORT``,
``serial:///dev/ttyX?baud=9600``), the :class:`BusLink` interface and a stream link."""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass
from typing import Protocol
from urllib.parse import parse_qs, urlsplit

DEFAULT_BAUD = 9600


class BusUrlError(ValueError):
    """A bus URL cannot be understood."""


@dataclass(frozen=True, slots=True)
class BusUrl:
    """Where the bus is: ``tcp`` (host, port) or ``serial`` (device, baud)."""

    scheme: str
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = DEFAULT_BAUD


def parse_bus_url(url: str) -> BusUrl:
    """``tcp://HOST:PORT`` or ``serial:///dev/ttyX[?baud=N]``."""
    parts = urlsplit(url)
    if parts.scheme == "tcp":
        try:
            port = parts.port
        except ValueError as exc:
            raise BusUrlError(f"{url}: bad port ({exc})") from None
        if not parts.hostname or port is None:
            raise BusUrlError(f"{url}: expected tcp://HOST:PORT")
        return BusUrl("tcp", host=parts.hostname, port=port)
    if parts.scheme == "serial":
        if parts.netloc or not parts.path.startswith("/"):
            raise BusUrlError(f"{url}: expected serial:///path/to/device[?baud=N]")
        query = parse_qs(parts.query, strict_parsing=False)
        unknown = set(query) - {"baud"}
        if unknown:
            raise BusUrlError(f"{url}: unknown option {sorted(unknown)[0]!r} (known: baud)")
        baud = DEFAULT_BAUD
        if "baud" in query:
            text = query["baud"][-1]
            if not text.isdigit() or int(text) <= 0:
                raise BusUrlError(f"{url}: baud must be a positive integer, not {text!r}")
            baud = int(text)
        return BusUrl("serial", device=parts.path, baud=baud)
    raise BusUrlError(f"{url}: unknown URL form (use tcp://HOST:PORT or serial:///dev/X?baud=N)")


class BusLink(Protocol):
    """A byte pipe to the bus."""

    async def send(self, data: bytes) -> None: ...

    async def receive(self) -> bytes:
        """Received bytes; ``b""`` once the link is closed."""
        ...

    async def close(self) -> None: ...


class StreamLink:
    """A link over asyncio streams (TCP or serial)."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._reader = reader
        self._writer = writer

    async def send(self, data: bytes) -> None:
        self._writer.write(data)
        await self._writer.drain()

    async def receive(self) -> bytes:
        try:
            return await self._reader.read(4096)
        except (ConnectionError, OSError):
            return b""

    async def close(self) -> None:
        self._writer.close()
        with contextlib.suppress(ConnectionError, OSError):
            await self._writer.wait_closed()


async def open_link(url: str | BusUrl) -> StreamLink:
    """Open the bus at ``url``."""
    where = parse_bus_url(url) if isinstance(url, str) else url
    if where.scheme == "tcp":
        reader, writer = await asyncio.open_connection(where.host, where.port)
    else:
        import serial_asyncio_fast

        reader, writer = await serial_asyncio_fast.open_serial_connection(
            url=where.device, baudrate=where.baud
        )
    return StreamLink(reader, writer)
