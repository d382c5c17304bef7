"""The mail hub's POP3 server: the pure session core over asyncio TCP and Maildirs."""

from __future__ import annotations

import asyncio
import contextlib
import logging

from ...protocol.pop3_server import Pop3Session, Pop3Store
from .pump import pump

log = logging.getLogger(__name__)


class Pop3Server:
    """A listening POP3 server; :meth:`close` also ends the sessions still open."""

    def __init__(self, store: Pop3Store, timeout: float) -> None:
        self._store = store
        self._timeout = timeout
        self._writers: set[asyncio.StreamWriter] = set()
        self._tasks: set[asyncio.Task[None]] = set()
        self.server: asyncio.Server | None = None

    async def serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        session = Pop3Session(self._store, timeout=self._timeout)
        self._writers.add(writer)
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        try:
            await pump(session, reader, writer)
        except Exception:  # one broken session never stops the server
            log.exception("POP3 session failed")
        finally:
            session.connection_lost()
            self._writers.discard(writer)
            if task is not None:
                self._tasks.discard(task)

    @property
    def port(self) -> int:
        assert self.server is not None
        port: int = self.server.sockets[0].getsockname()[1]
        return port

    async def close(self) -> None:
        if self.server is not None:
            self.server.close()
        for writer in list(self._writers):
            writer.close()  # the session's pump sees the end and releases its mailbox
        if self._tasks:
            await asyncio.wait(list(self._tasks), timeout=5)
        if self.server is not None:
            with contextlib.suppress(OSError):
                await self.server.wait_closed()


async def start_pop3_server(
    store: Pop3Store, host: str, port: int, *, timeout: float = 600.0
) -> Pop3Server:
    """Listen on ``host:port`` (0: any free port); one :class:`Pop3Session` per client."""
    pop3 = Pop3Server(store, timeout)
    pop3.server = await asyncio.start_server(pop3.serve, host, port)
    return pop3
