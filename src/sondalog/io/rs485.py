"""RS-485 ports for the HCTMPS1 bus, on both sides of the line (hctmps1.md §1, §2).

RS-485 is half duplex: the side that talks enables its line driver (DE, usually wired to
the UART's RTS) for exactly as long as its frame lasts. Three ways to get that on Linux
(:func:`open_port`):

- ``kernel``: the UART driver toggles RTS itself (``TIOCSRS485``; Raspberry Pi PL011 and
  8250 UARTs, many USB adapters' drivers). The best choice where the driver supports it.
- ``rts``: pyserial's :class:`serial.rs485.RS485` raises RTS, writes, waits until the last
  stop bit has left (``tcdrain``) and drops RTS. Works on any UART with an RTS line, but the
  write blocks for the frame's duration.
- ``auto``: the adapter switches direction by itself (most USB RS-485 sticks); the port is a
  plain 8N1 port.

:class:`AsyncPort` puts such a port on the event loop: reads through the loop's reader on
the file descriptor, writes in a worker thread of their own (one at a time, in order), so the
blocking ``rts`` write never stalls the loop. :class:`Rs485Line` attaches one to a
:class:`~sondalog.io.host.DeviceHost` (the bus served on a real adapter);
the bus master's serial link (``client/bus_links.py``) uses :class:`AsyncPort` directly.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Literal

from sondalog.io.host import DeviceHost
from sondalog.io.serial_ports import serial_8n1

log = logging.getLogger(__name__)

Mode = Literal["kernel", "rts", "auto"]
MODES: tuple[Mode, ...] = ("kernel", "rts", "auto")
#: Seconds between attempts to reopen a port that went away (a USB adapter unplugged).
REOPEN_DELAY = 1.0


class Rs485Error(ValueError):
    """The port cannot be driven as asked (settings out of range, mode not supported)."""


def open_port(
    port: str,
    baud: int = 9600,
    *,
    mode: Mode = "kernel",
    delay_before_tx: float = 0.0,
    delay_before_rx: float = 0.0,
    rts_level_for_tx: bool = True,
    timeout: float | None = 0.0,
) -> Any:
    """Open ``port`` 8N1 at ``baud`` as an RS-485 line in ``mode``; a pyserial ``Serial``.

    Raises :class:`Rs485Error` when the port cannot do the mode (a pty, or a UART whose driver
    lacks ``TIOCSRS485``, in ``kernel`` mode; a port without modem lines in ``rts`` mode) and
    ``serial.SerialException`` (an OSError) when it cannot be opened at all.
    """
    import serial
    import serial.rs485

    if mode not in MODES:
        raise Rs485Error(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    settings = serial.rs485.RS485Settings(
        rts_level_for_tx=rts_level_for_tx,
        rts_level_for_rx=not rts_level_for_tx,
        delay_before_tx=delay_before_tx,
        delay_before_rx=delay_before_rx,
    )
    cls = serial.rs485.RS485 if mode == "rts" else serial.Serial
    line = cls(port, baud, timeout=timeout, **serial_8n1())
    try:
        if mode == "kernel":
            line.rs485_mode = settings  # TIOCSRS485 on Linux
        elif mode == "rts":
            line.rts = not rts_level_for_tx  # receiving until the first write
            line.rs485_mode = settings  # pyserial toggles RTS around each write
    except (ValueError, OSError) as exc:
        line.close()
        hint = (
            "the port's driver has no kernel RS-485 mode (a pty or a plain USB serial "
            "adapter): use mode = 'rts' or 'auto'"
            if mode == "kernel"
            else "the port has no RTS line (a pty?): use mode = 'auto'"
        )
        raise Rs485Error(f"{port}: {mode} RS-485 mode not supported: {exc}; {hint}") from None
    return line


class AsyncPort:
    """A pyserial port on the running event loop: :meth:`read` and :meth:`write` never block
    the loop (writes run in the port's own worker thread, in order)."""

    def __init__(self, port: Any) -> None:
        self.port = port
        self._fd: int = port.fileno()
        self._loop = asyncio.get_running_loop()
        self._incoming: asyncio.Queue[bytes] = asyncio.Queue()
        self._writer = ThreadPoolExecutor(1, thread_name_prefix=f"rs485 {port.port}")
        self._open = True
        self._loop.add_reader(self._fd, self._readable)

    def _readable(self) -> None:
        try:
            data = os.read(self._fd, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # EIO: the other end of a pty closed, the adapter went away
            data = b""
        if not data:
            self._loop.remove_reader(self._fd)
        self._incoming.put_nowait(data)

    async def read(self) -> bytes:
        """The next bytes received; ``b""`` once the port is gone or closed."""
        if not self._open and self._incoming.empty():
            return b""
        data = await self._incoming.get()
        if not data:
            self._incoming.put_nowait(b"")  # every later read sees the end too
        return data

    async def write(self, data: bytes) -> None:
        """Send ``data``; returns when the port took it (in ``rts`` mode: when the last
        stop bit has left and the driver is released)."""
        if self._open:
            await self._loop.run_in_executor(self._writer, self._write, data)

    def _write(self, data: bytes) -> None:
        self.port.write(data)

    def close(self) -> None:
        if not self._open:
            return
        self._open = False
        with contextlib.suppress(ValueError, OSError):
            self._loop.remove_reader(self._fd)
        self._incoming.put_nowait(b"")
        self._writer.shutdown(wait=False, cancel_futures=True)  # a stuck write never hangs us
        with contextlib.suppress(OSError):
            self.port.close()


class Rs485Line:
    """A real RS-485 adapter as a line of a device (the HCTMPS1 bus served on it).

    ``opener`` opens the port (:func:`open_port` with the site's settings); when the port
    goes away it is reopened every :data:`REOPEN_DELAY` seconds."""

    def __init__(self, host: DeviceHost, opener: Callable[[], Any], name: str) -> None:
        self._host = host
        self._opener = opener
        self.name = name
        self._port: AsyncPort | None = None
        self._line: int | None = None
        self._out: asyncio.Queue[tuple[int, bytes]] = asyncio.Queue()
        self._tasks: list[asyncio.Task[None]] = []

    async def open(self) -> None:
        """Open the port (raises :class:`Rs485Error` or OSError when it cannot)."""
        self._connect()
        self._tasks = [
            asyncio.create_task(self._read_loop(), name=f"rs485 in {self.name}"),
            asyncio.create_task(self._write_loop(), name=f"rs485 out {self.name}"),
        ]

    def _connect(self) -> None:
        port = AsyncPort(self._opener())
        line = self._host.attach(lambda data: self._out.put_nowait((line, data)), paced=True)
        self._port, self._line = port, line
        log.info("line %d: RS-485 %s", line, self.name)

    def _disconnect(self) -> None:
        if self._line is not None:
            self._host.detach(self._line)
            self._line = None
        if self._port is not None:
            self._port.close()
            self._port = None

    async def _read_loop(self) -> None:
        while True:
            port = self._port
            data = await port.read() if port is not None else b""
            if data:
                if self._line is not None:
                    self._host.feed(self._line, data)
                continue
            self._disconnect()
            log.warning("RS-485 %s lost; reopening", self.name)
            while self._port is None:
                await asyncio.sleep(REOPEN_DELAY)
                try:
                    self._connect()
                except (OSError, ValueError) as exc:
                    log.debug("RS-485 %s: %s", self.name, exc)

    async def _write_loop(self) -> None:
        while True:
            line, data = await self._out.get()
            if line == self._line and self._port is not None:
                try:
                    await self._port.write(data)
                except (OSError, ValueError) as exc:
                    log.warning("RS-485 %s: write failed: %s", self.name, exc)

    async def close(self) -> None:
        for task in self._tasks:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks = []
        self._disconnect()
