"""External ports of the virtual bus: TCP gateway, pty with a stable symlink, serial line.

Each is a thin adapter between a byte stream and a :class:`~sondalog.io.bus_runner.BusPort`.
Every TCP connection is its own node on the bus, as if each client had its own TCP-to-RS-485
gateway: it does not hear its own bytes, but hears every other node, other hosts included.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import os
from pathlib import Path

from sondalog.io.bus_runner import BusPort, VirtualBus
from sondalog.io.serial_ports import PtyLink

log = logging.getLogger(__name__)


async def _pump(reader: asyncio.StreamReader, port: BusPort) -> None:
    while data := await reader.read(4096):
        port.write(data)


async def serve_tcp(bus: VirtualBus, host: str, port: int) -> asyncio.Server:
    """Listen on ``host:port``; every connection becomes a host port of the bus."""

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        bus_port = bus.open_port()

        def send(data: bytes) -> None:
            if not writer.is_closing():
                writer.write(data)

        bus_port.on_data = send
        peer = writer.get_extra_info("peername")
        log.info("bus: TCP host %s attached", peer)
        try:
            await _pump(reader, bus_port)
        except (ConnectionError, OSError) as exc:
            log.info("bus: TCP host %s: %s", peer, exc)
        finally:
            bus_port.detach()
            writer.close()
            with contextlib.suppress(ConnectionError, OSError):
                await writer.wait_closed()
            log.info("bus: TCP host %s detached", peer)

    return await asyncio.start_server(handle, host, port)


class PtyPort:
    """A pseudo-terminal attached to the bus, reachable through a stable symlink.

    The slave side (``/dev/pts/N``) is what a host program opens, through ``link``. The server
    keeps the slave open as well, so a host may close and reopen it without a hang-up. Bytes the
    bus delivers while nobody reads are dropped once the pty's buffer is full, as on a serial
    line with no one listening.
    """

    def __init__(self, bus: VirtualBus, link: Path) -> None:
        self.link = link
        self._pty = PtyLink(link, keep_slave=True)
        self._master = self._pty.master
        self.device = self._pty.device
        self.port = bus.open_port()
        self.port.on_data = self._send
        asyncio.get_running_loop().add_reader(self._master, self._readable)

    def _readable(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            return
        except OSError as exc:
            if exc.errno != errno.EIO:
                log.warning("bus pty %s: %s", self.device, exc)
            return
        if data:
            self.port.write(data)

    def _send(self, data: bytes) -> None:
        try:
            os.write(self._master, data)
        except BlockingIOError:
            log.debug("bus pty %s: nobody reads, %d bytes dropped", self.device, len(data))

    def close(self) -> None:
        with contextlib.suppress(ValueError, RuntimeError):
            asyncio.get_running_loop().remove_reader(self._master)
        self.port.detach()
        self._pty.close()


async def open_serial(bus: VirtualBus, device: str, baud: int) -> asyncio.Task[None]:
    """Attach a real serial port (a USB RS-485 adapter, say) to the bus; returns its pump."""
    import serial_asyncio_fast  # imported here: only this port needs it

    reader, writer = await serial_asyncio_fast.open_serial_connection(url=device, baudrate=baud)
    port = bus.open_port()
    port.on_data = writer.write

    async def run() -> None:
        try:
            await _pump(reader, port)
        finally:
            port.detach()
            writer.close()

    return asyncio.create_task(run(), name=f"serial {device}")
