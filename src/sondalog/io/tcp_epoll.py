"""Short TCP connections on one epoll of the event loop: the collector's contacts (issue 24).

A collector of ten thousand sources opens and closes 167 connections a second, each for one
write and one answer. Through ``loop.create_connection`` each costs a transport of the loop
(on uvloop a libuv handle made, tracked in a weak dictionary, its addresses read, closed
through a callback) beside the kernel's own work. Here the loop watches one descriptor, an
``epoll`` of this module, and the connections are plain non-blocking sockets registered in
it: an event costs one ``epoll_ctl``, a read one ``recv``.

:func:`open_connection` gives what ``loop.create_connection`` gives: a transport (``write``,
``close``, ``is_closing``, ``get_extra_info``) and the protocol built by the factory, which
sees ``connection_made``, ``data_received`` and ``connection_lost`` as an asyncio protocol
does (the end of the peer's data closes the connection: ``connection_lost(None)``; an error
``connection_lost(exc)``). A refused or failed connect raises the ``OSError`` of its errno
(``ConnectionRefusedError: [Errno 111] Connection refused``), as uvloop does. Names are
resolved through the loop's ``getaddrinfo`` once per endpoint (:class:`Resolved`), again
after a failed connect. Where the platform has no epoll, :func:`available` is False and the
caller goes through the loop's transports.
"""

from __future__ import annotations

import asyncio
import errno
import ipaddress
import os
import select
import socket
import weakref
from collections.abc import Callable
from typing import Any, TypeVar

_P = TypeVar("_P", bound=asyncio.Protocol)

#: Bytes read at most per readable event.
READ_SIZE = 65536
_IN = getattr(select, "EPOLLIN", 1)
_OUT = getattr(select, "EPOLLOUT", 4)
_ERRS = getattr(select, "EPOLLERR", 8) | getattr(select, "EPOLLHUP", 16)


def available() -> bool:
    """This platform has epoll (Linux)."""
    return hasattr(select, "epoll")


class _Poller:
    """The epoll of one loop and the connections in it (fd -> its event handler)."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = weakref.proxy(loop)  # the loop's entry in _OF must not keep it alive
        self.epoll = select.epoll()
        self.handlers: dict[int, Callable[[int], None]] = {}
        loop.add_reader(self.epoll.fileno(), self._ready)

    def add(self, fd: int, events: int, handler: Callable[[int], None]) -> None:
        self.handlers[fd] = handler
        self.epoll.register(fd, events)

    def change(self, fd: int, events: int, handler: Callable[[int], None]) -> None:
        self.handlers[fd] = handler
        self.epoll.modify(fd, events)

    def remove(self, fd: int) -> None:
        if self.handlers.pop(fd, None) is not None:
            self.epoll.unregister(fd)

    def _ready(self) -> None:
        for fd, events in self.epoll.poll(0, 256):
            handler = self.handlers.get(fd)
            if handler is not None:
                handler(events)


_OF: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, _Poller] = weakref.WeakKeyDictionary()


def _poller(loop: asyncio.AbstractEventLoop) -> _Poller:
    found = _OF.get(loop)
    if found is None:
        found = _OF[loop] = _Poller(loop)
    return found


class EpollTransport:
    """A connected socket in the loop's epoll, with the transport methods a client uses."""

    def __init__(self, poller: _Poller, sock: socket.socket, protocol: asyncio.Protocol) -> None:
        self._poller = poller
        self._sock = sock
        self._fd = sock.fileno()
        self._protocol = protocol
        self._out = bytearray()  # what the socket did not take yet
        self._closed = False

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        if name == "socket":
            return self._sock
        if name == "peername":
            return self._sock.getpeername() if not self._closed else default
        if name == "sockname":
            return self._sock.getsockname() if not self._closed else default
        return default

    def is_closing(self) -> bool:
        return self._closed

    def write(self, data: bytes | bytearray | memoryview) -> None:
        if self._closed or not data:
            return
        if self._out:
            self._out += data
            return
        try:
            sent = self._sock.send(data)
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError as exc:
            self._lost(exc)
            return
        if sent < len(data):
            self._out += data[sent:]
            self._poller.change(self._fd, _IN | _OUT, self._event)

    def close(self) -> None:
        """Close now; the protocol's ``connection_lost(None)`` comes soon after (unsent
        bytes are dropped: a client closes once it has its answer)."""
        if not self._closed:
            self._finish()
            self._poller.loop.call_soon(self._protocol.connection_lost, None)

    def abort(self) -> None:
        self.close()

    def _finish(self) -> None:
        self._closed = True
        self._poller.remove(self._fd)
        self._sock.close()
        self._out.clear()

    def _lost(self, exc: Exception | None) -> None:
        if not self._closed:
            self._finish()
            self._protocol.connection_lost(exc)

    def _event(self, events: int) -> None:
        if events & _OUT and self._out:
            try:
                sent = self._sock.send(self._out)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError as exc:
                self._lost(exc)
                return
            del self._out[:sent]
            if not self._out:
                self._poller.change(self._fd, _IN, self._event)
        if events & (_IN | _ERRS):
            try:
                data = self._sock.recv(READ_SIZE)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                self._lost(exc)
                return
            if data:
                self._protocol.data_received(data)
            else:  # the peer's end of data: closed, as an asyncio protocol without eof_received
                self._lost(None)


class Resolved:
    """``host:port`` resolved once (an address literal needs no lookup); :meth:`forget`
    after a failed connect looks it up again next time."""

    def __init__(self, host: str, port: int) -> None:
        self.host, self.port = host, port
        self._found: tuple[int, Any] | None = None
        self._literal = False
        try:
            ip = ipaddress.ip_address(host)
        except ValueError:
            return
        family = socket.AF_INET6 if ip.version == 6 else socket.AF_INET
        self._found, self._literal = (family, (host, port)), True

    async def address(self, loop: asyncio.AbstractEventLoop) -> tuple[int, Any]:
        if self._found is None:
            infos = await loop.getaddrinfo(
                self.host, self.port, type=socket.SOCK_STREAM, proto=socket.IPPROTO_TCP
            )
            if not infos:
                raise OSError(f"getaddrinfo({self.host!r}) returned no address")
            family, _, _, _, address = infos[0]
            self._found = (family, address)
        return self._found

    def forget(self) -> None:
        if not self._literal:
            self._found = None


async def open_connection(
    resolved: Resolved, factory: Callable[[], _P]
) -> tuple[EpollTransport, _P]:
    """Connect to ``resolved`` (see the module docstring)."""
    loop = asyncio.get_running_loop()
    family, address = await resolved.address(loop)
    poller = _poller(loop)
    sock = socket.socket(family, socket.SOCK_STREAM)
    fd = sock.fileno()
    try:
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            sock.connect(address)
            code = 0
        except (BlockingIOError, InterruptedError):
            code = await _connected(poller, sock)
        if code:
            raise OSError(code, os.strerror(code))
    except BaseException as exc:
        poller.remove(fd)
        sock.close()
        if isinstance(exc, OSError) and exc.errno != errno.EINTR:
            resolved.forget()
        raise
    protocol = factory()
    transport = EpollTransport(poller, sock, protocol)
    if fd in poller.handlers:  # registered for the connect: now for reading
        poller.change(fd, _IN, transport._event)
    else:
        poller.add(fd, _IN, transport._event)
    protocol.connection_made(transport)  # type: ignore[arg-type]
    return transport, protocol


async def _connected(poller: _Poller, sock: socket.socket) -> int:
    """Wait until ``sock``'s connect ends (left registered); its error code (0: connected)."""
    connected: asyncio.Future[int] = poller.loop.create_future()
    poller.add(sock.fileno(), _OUT, lambda events: _done(connected, events))
    await connected
    return sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)


def _done(future: asyncio.Future[int], events: int) -> None:
    if not future.done():
        future.set_result(events)
