"""Links to an RS-485 bus for the bus master: URLs (``tcp://HOST:PORT``,
``serial:///dev/ttyX?baud=9600[&rs485=kernel|rts|auto]``), the :class:`BusLink` interface,
a stream link and an RS-485 link that keeps the bus timing (:class:`Rs485Link`)."""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass
from typing import Protocol
from urllib.parse import parse_qs, urlsplit

from sondalog.io.rs485 import MODES, AsyncPort, Mode, Rs485Error, open_port
from sondalog.protocol.hctmps1_frames import inter_frame_gap

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
    rs485: Mode | None = None  # how the port drives an RS-485 line (serial only)


def parse_bus_url(url: str) -> BusUrl:
    """``tcp://HOST:PORT`` or ``serial:///dev/ttyX[?baud=N][&rs485=kernel|rts|auto]``."""
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
        unknown = set(query) - {"baud", "rs485"}
        if unknown:
            raise BusUrlError(f"{url}: unknown option {sorted(unknown)[0]!r} (known: baud, rs485)")
        baud = DEFAULT_BAUD
        if "baud" in query:
            text = query["baud"][-1]
            if not text.isdigit() or int(text) <= 0:
                raise BusUrlError(f"{url}: baud must be a positive integer, not {text!r}")
            baud = int(text)
        rs485: Mode | None = None
        if "rs485" in query:
            mode = query["rs485"][-1]
            if mode not in MODES:
                raise BusUrlError(f"{url}: rs485 must be one of {', '.join(MODES)}, not {mode!r}")
            rs485 = mode
        return BusUrl("serial", device=parts.path, baud=baud, rs485=rs485)
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


class Rs485Link:
    """The bus master on an RS-485 adapter (``serial://...?rs485=MODE``): writes never block
    the loop (``rts`` mode blocks in ``write()``, so writes run in the port's thread), and
    each request waits for :func:`inter_frame_gap` of idle line after the last byte heard or
    sent, so a late answer is never overrun."""

    def __init__(self, port: AsyncPort, baud: int) -> None:
        self.port = port
        self.baud = baud
        self.gap = inter_frame_gap(baud)
        self._loop = asyncio.get_running_loop()
        self._busy_until = self._loop.time()  # the line's last activity, loop time

    async def send(self, data: bytes) -> None:
        wait = self._busy_until + self.gap - self._loop.time()
        if wait > 0:
            await asyncio.sleep(wait)
        start = self._loop.time()
        await self.port.write(data)
        # kernel and auto modes return once the bytes are queued: the frame still runs
        self._busy_until = max(self._loop.time(), start + len(data) * 10 / self.baud)

    async def receive(self) -> bytes:
        data = await self.port.read()
        self._busy_until = max(self._busy_until, self._loop.time())
        return data

    async def close(self) -> None:
        self.port.close()


async def open_link(url: str | BusUrl) -> StreamLink | Rs485Link:
    """Open the bus at ``url``."""
    where = parse_bus_url(url) if isinstance(url, str) else url
    if where.rs485 is not None:
        loop = asyncio.get_running_loop()
        mode = where.rs485
        try:
            port = await loop.run_in_executor(
                None, lambda: open_port(where.device, where.baud, mode=mode)
            )
        except Rs485Error as exc:  # the port cannot do the mode: like an unreachable bus
            raise OSError(str(exc)) from None
        return Rs485Link(AsyncPort(port), where.baud)
    if where.scheme == "tcp":
        reader, writer = await asyncio.open_connection(where.host, where.port)
    else:
        import serial_asyncio_fast

        reader, writer = await serial_asyncio_fast.open_serial_connection(
            url=where.device, baudrate=where.baud
        )
    return StreamLink(reader, writer)
