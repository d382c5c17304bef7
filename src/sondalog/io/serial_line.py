"""A real serial port as a line of a device (``logger serve --serial``, ``bus serve --serial``).

The port is opened at the device's line speed (ALA1 ``com speed``, the bus baud rate), 8N1,
without hardware or software flow control in the driver: XON/XOFF are the engine's (§6.11.1).
The line is paced by the core; this adapter writes what it gets and sets the port's rate to
the rate each piece was paced at (:attr:`~sondalog.protocol.device.LineSend.baud`: a
``comspeed`` answer, §8.5.2) and back to the line speed when the output is idle (a written
``com speed`` after its ``OK``, §6.11.2). Before the rate changes, the bytes already written
are drained (``tcdrain``) so that none leaves at the wrong rate. A baud mismatch with the host
is the hardware's business here: the UART makes garbage.

A serial port has no connect/disconnect: the line opens with the port. When the device goes
away (a USB adapter unplugged) the line disconnects and the port is reopened every
:data:`REOPEN_DELAY` seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

from sondalog.io.host import DeviceHost
from sondalog.io.serial_ports import serial_8n1
from sondalog.protocol.device import LineSend

log = logging.getLogger(__name__)

REOPEN_DELAY = 1.0
#: The engine hands paced output over in pieces of about 10 ms of line time; a line silent
#: for longer than this has finished its answer, and the port returns to ``com speed``.
IDLE = 0.05


class _SerialProtocol(asyncio.Protocol):
    def __init__(self, owner: SerialLine) -> None:
        self._owner = owner
        self.lost = asyncio.get_running_loop().create_future()

    def data_received(self, data: bytes) -> None:
        self._owner.received(data)

    def connection_lost(self, exc: Exception | None) -> None:
        if not self.lost.done():
            self.lost.set_result(exc)


class SerialLine:
    """One serial device attached to an :class:`DeviceHost` as a paced line."""

    def __init__(self, host: DeviceHost, device: str) -> None:
        self._host = host
        self.device = device
        self._line: int | None = None
        self._transport: Any = None  # serial_asyncio_fast.SerialTransport
        self._baud = host.device.line_speed()
        self._outputs: asyncio.Queue[LineSend] = asyncio.Queue()
        self._runner: asyncio.Task[None] | None = None
        self._writer: asyncio.Task[None] | None = None

    @property
    def baud(self) -> int:
        """The rate the port is set to now."""
        return self._baud

    async def open(self) -> None:
        """Open the port (raises OSError / serial.SerialException when it cannot)."""
        protocol = await self._connect()
        self._runner = asyncio.create_task(self._run(protocol), name=f"serial {self.device}")
        self._writer = asyncio.create_task(self._write_loop(), name=f"serial out {self.device}")

    async def _connect(self) -> _SerialProtocol:
        import serial_asyncio_fast  # imported here: only this line needs it

        self._baud = self._host.device.line_speed()
        loop = asyncio.get_running_loop()
        transport, protocol = await serial_asyncio_fast.create_serial_connection(
            loop,
            lambda: _SerialProtocol(self),
            self.device,
            baudrate=self._baud,
            **serial_8n1(),
        )
        assert isinstance(protocol, _SerialProtocol)
        self._transport = transport
        self._line = self._host.attach_output(self._outputs.put_nowait, paced=True)
        log.info("line %d: serial %s at %d baud", self._line, self.device, self._baud)
        return protocol

    async def _run(self, protocol: _SerialProtocol) -> None:
        while True:
            exc = await protocol.lost
            self._disconnect()
            log.warning("serial %s lost (%s); reopening", self.device, exc)
            while True:
                await asyncio.sleep(REOPEN_DELAY)
                try:
                    protocol = await self._connect()
                    break
                except Exception as error:
                    log.debug("serial %s: %s", self.device, error)

    def _disconnect(self) -> None:
        if self._line is not None:
            self._host.detach(self._line)
            self._line = None
        self._transport = None
        while not self._outputs.empty():
            self._outputs.get_nowait()

    def received(self, data: bytes) -> None:
        if self._line is not None:
            self._host.feed(self._line, data)

    async def _write_loop(self) -> None:
        while True:
            try:
                output = await asyncio.wait_for(self._outputs.get(), IDLE)
            except TimeoutError:  # the answer is over: listen at com speed again
                await self._set_baud(self._host.device.line_speed())
                output = await self._outputs.get()
            if output.line != self._line or self._transport is None:
                continue
            await self._set_baud(output.baud or self._host.device.line_speed())
            self._transport.write(output.data)

    async def _set_baud(self, baud: int) -> None:
        transport = self._transport
        if baud == self._baud or transport is None:
            return
        while transport.get_write_buffer_size():
            await asyncio.sleep(0.001)
        port = transport.serial
        await asyncio.get_running_loop().run_in_executor(None, port.flush)  # tcdrain
        port.baudrate = baud
        self._baud = baud
        log.debug("serial %s: now %d baud", self.device, baud)

    async def close(self) -> None:
        for task in (self._runner, self._writer):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        transport = self._transport
        self._disconnect()
        if transport is not None:
            transport.close()
