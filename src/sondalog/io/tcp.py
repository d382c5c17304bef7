"""TCP transport for an ALA1 engine (§6.11.5.2.4: the GPRS modem listens on TCP port 10001).

Every accepted connection is one line of the engine (its own echo and partial command, §3.4);
each answer goes back to the connection that sent the command. Bytes are passed through
unchanged in both directions, as ``telnet``/``nc`` would see a real module through the modem.
With ``paced`` (``--line-rate``) the engine releases answers at ``com speed``.
"""

from __future__ import annotations

import asyncio
import errno
import functools
import ipaddress
import logging
import random
import socket
from pathlib import Path
from typing import cast

from sondalog.io.host import DeviceHost

log = logging.getLogger(__name__)

#: §6.11.5.2.4: the TCP server of the ALA GPRS modem.
DEFAULT_PORT = 10001
#: Stop reading from a client whose answers pile up unread beyond this many bytes.
HIGH_WATER = 256 * 1024


class _LineProtocol(asyncio.Protocol):
    """One TCP connection = one engine line."""

    def __init__(
        self, host: DeviceHost, connections: set[_LineProtocol], paced: bool = False
    ) -> None:
        self._host = host
        self._connections = connections
        self._paced = paced
        self._transport: asyncio.Transport | None = None
        self._line: int | None = None
        # Reading stops while either holds: the runtime has too much of this line's input
        # queued (or the logger holds no more of it, issue 20), or the client does not read
        # its answers. Each reason alone must not resume what the other paused.
        self._input_full = False
        self._output_full = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # uvloop's transports are not asyncio.Transport subclasses: take the interface.
        stream = self._transport = cast(asyncio.Transport, transport)
        stream.set_write_buffer_limits(high=HIGH_WATER)
        self._line = self._host.attach(self._send, paced=self._paced, flow=self)
        self._connections.add(self)
        log.info("line %d: connected from %s", self._line, stream.get_extra_info("peername"))

    def data_received(self, data: bytes) -> None:
        if self._line is not None:
            self._host.feed(self._line, data)

    def eof_received(self) -> bool | None:
        return None  # close our side too: the peer has finished talking

    def connection_lost(self, exc: Exception | None) -> None:
        self._connections.discard(self)
        if self._line is not None:
            log.info("line %d: disconnected (%s)", self._line, exc or "closed")
            self._host.detach(self._line)
            self._line = None
        self._transport = None

    # Flow control: a client that pipelines commands without reading its answers is paused.
    def pause_writing(self) -> None:
        self._output_full = True
        self._steer()

    def resume_writing(self) -> None:
        self._output_full = False
        self._steer()

    # ... and so is one whose input the runtime cannot run yet (host.FlowControl).
    def pause_reading(self) -> None:
        self._input_full = True
        self._steer()

    def resume_reading(self) -> None:
        self._input_full = False
        self._steer()

    def _steer(self) -> None:
        stream = self._transport
        if stream is None or stream.is_closing():
            return
        if self._input_full or self._output_full:
            stream.pause_reading()
        else:
            stream.resume_reading()

    def _send(self, data: bytes) -> None:
        if self._transport is not None and not self._transport.is_closing():
            self._transport.write(data)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()


class TcpServer:
    """A listening TCP server attached to one :class:`DeviceHost`."""

    def __init__(self, server: asyncio.Server, connections: set[_LineProtocol]) -> None:
        self.server = server
        self._connections = connections

    @property
    def address(self) -> tuple[str, int]:
        """The (host, port) actually bound (port 0 picks a free port)."""
        sockname = self.server.sockets[0].getsockname()
        return str(sockname[0]), int(sockname[1])

    async def close(self) -> None:
        """Stop accepting and drop every connection."""
        self.server.close()
        for connection in list(self._connections):
            connection.close()
        await self.server.wait_closed()


async def serve_tcp(host: DeviceHost, address: str, port: int, *, paced: bool = False) -> TcpServer:
    """Listen on ``address:port`` and attach each connection to ``host`` as its own line.

    ``paced`` (``--line-rate``): answers leave at ``com speed`` as on a serial line (§6.11.2).
    """
    connections: set[_LineProtocol] = set()
    loop = asyncio.get_running_loop()

    def protocol() -> _LineProtocol:
        return _LineProtocol(host, connections, paced)

    sock = free_port_socket(address) if port == 0 else None
    if sock is not None:
        server = await loop.create_server(protocol, sock=sock)
    else:
        server = await loop.create_server(protocol, address, port, reuse_address=True)
    return TcpServer(server, connections)


#: The next port :func:`free_port_socket` tries (a random start per process).
_next_port: list[int] = []


@functools.cache
def _port_range() -> tuple[int, int]:
    """The kernel's ephemeral ports (where it looks for port 0 itself)."""
    try:
        low, high = Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()
        return int(low), int(high)
    except (OSError, ValueError):
        return 32768, 60999


@functools.lru_cache(maxsize=64)
def _family(address: str) -> socket.AddressFamily | None:
    """The socket family of a literal IP address; None for a host name (parsed once: a
    fleet binds thousands of sockets on one address, issue 24)."""
    try:
        return socket.AF_INET6 if ipaddress.ip_address(address).version == 6 else socket.AF_INET
    except ValueError:
        return None


def free_port_socket(address: str) -> socket.socket | None:
    """A socket bound to a free port of the ephemeral range on ``address`` (a literal IP
    address; None for a host name: the event loop binds it to port 0 itself).

    Ports are tried in turn from where the last search ended: with thousands of ports bound
    (a fleet, issue 24) the kernel's own search for port 0 costs milliseconds a bind, an
    explicit port tens of microseconds."""
    family = _family(address)
    if family is None:
        return None
    low, high = _port_range()
    span = high - low + 1
    if not _next_port:
        _next_port.append(random.randrange(low, high + 1))
    start = _next_port[0]
    for step in range(span):
        candidate = low + (start - low + step) % span
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((address, candidate))
        except OSError as exc:
            sock.close()
            if exc.errno in (errno.EADDRINUSE, errno.EACCES):
                continue
            raise
        _next_port[0] = low + (candidate + 1 - low) % span
        return sock
    raise OSError(errno.EADDRINUSE, f"no free port on {address}")
