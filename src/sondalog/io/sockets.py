"""Real TCP connections and listeners named by numbers, for a pure core that speaks in
effects (the GSM network's IP gateway, ``docs/gsm.md``).

The core says "connect ``conn`` to host:port", "send on ``conn``", "listen as ``listener`` on
host:port"; :class:`SocketPool` does it with asyncio and reports back through
:class:`SocketEvents` callbacks: connected, failed, data, closed, accepted. Connections the
pool accepts get numbers from :data:`ACCEPTED_BASE` up, so they never meet the core's own.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from dataclasses import dataclass
from typing import Protocol, cast

log = logging.getLogger(__name__)

#: Numbers of accepted connections start here.
ACCEPTED_BASE = 1 << 40


class SocketEvents(Protocol):
    def connected(self, conn: int) -> None: ...

    def failed(self, conn: int) -> None: ...

    def data(self, conn: int, data: bytes) -> None: ...

    def closed(self, conn: int) -> None: ...

    def accepted(self, listener: int, conn: int) -> None: ...


class _Conn(asyncio.Protocol):
    def __init__(self, pool: SocketPool, conn: int, listener: int | None = None) -> None:
        self.pool = pool
        self.conn = conn
        self.listener = listener
        self.transport: asyncio.Transport | None = None
        self.closing = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.Transport, transport)
        self.pool._conns[self.conn] = self
        if self.listener is not None:
            self.pool.events.accepted(self.listener, self.conn)

    def data_received(self, data: bytes) -> None:
        self.pool.events.data(self.conn, data)

    def eof_received(self) -> bool | None:
        return None

    def connection_lost(self, exc: Exception | None) -> None:
        if self.pool._conns.pop(self.conn, None) is not None and not self.closing:
            self.pool.events.closed(self.conn)


@dataclass
class _Listener:
    server: asyncio.Server


class SocketPool:
    """The sockets of one core; :meth:`close_all` ends them."""

    def __init__(self, events: SocketEvents) -> None:
        self.events = events
        self._conns: dict[int, _Conn] = {}
        self._listeners: dict[int, _Listener] = {}
        self._pending: dict[int, asyncio.Task[None]] = {}
        self._next_accepted = ACCEPTED_BASE

    def connect(self, conn: int, host: str, port: int) -> None:
        task = asyncio.get_running_loop().create_task(self._connect(conn, host, port))
        self._pending[conn] = task

    async def _connect(self, conn: int, host: str, port: int) -> None:
        loop = asyncio.get_running_loop()
        try:
            await loop.create_connection(lambda: _Conn(self, conn), host, port)
        except OSError as exc:
            log.info("gateway connection %d to %s:%d failed: %s", conn, host, port, exc)
            self.events.failed(conn)
        else:
            self.events.connected(conn)
        finally:
            self._pending.pop(conn, None)

    def send(self, conn: int, data: bytes) -> None:
        c = self._conns.get(conn)
        if c is not None and c.transport is not None and not c.transport.is_closing():
            c.transport.write(data)

    def close(self, conn: int) -> None:
        """Close ``conn`` (the core asked: no ``closed`` callback)."""
        task = self._pending.pop(conn, None)
        if task is not None:
            task.cancel()
        c = self._conns.pop(conn, None)
        if c is not None and c.transport is not None:
            c.closing = True
            c.transport.close()

    async def listen(self, listener: int, host: str, port: int) -> None:
        def factory() -> _Conn:
            self._next_accepted += 1
            return _Conn(self, self._next_accepted, listener)

        loop = asyncio.get_running_loop()
        try:
            server = await loop.create_server(factory, host, port, reuse_address=True)
        except OSError as exc:
            log.warning("cannot listen on %s:%d: %s", host, port, exc)
            return
        self._listeners[listener] = _Listener(server)

    def unlisten(self, listener: int) -> None:
        entry = self._listeners.pop(listener, None)
        if entry is not None:
            entry.server.close()

    def listening(self) -> list[tuple[str, int]]:
        """The host addresses listened on now."""
        out = []
        for entry in self._listeners.values():
            name = entry.server.sockets[0].getsockname()
            out.append((str(name[0]), int(name[1])))
        return out

    async def close_all(self) -> None:
        for task in list(self._pending.values()):
            task.cancel()
        for conn in list(self._conns):
            self.close(conn)
        for listener in list(self._listeners):
            entry = self._listeners.pop(listener)
            entry.server.close()
            with contextlib.suppress(Exception):
                await entry.server.wait_closed()
