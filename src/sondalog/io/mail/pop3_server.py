"""The mail hub's POP3 server: the pure session core over asyncio TCP and Maildirs."""

from __future__ import annotations

import asyncio
import logging

from ...protocol.pop3_server import Pop3Session, Pop3Store
from .pump import pump

log = logging.getLogger(__name__)


async def start_pop3_server(
    store: Pop3Store, host: str, port: int, *, timeout: float = 600.0
) -> asyncio.Server:
    """Listen on ``host:port`` (0: any free port); one :class:`Pop3Session` per client."""

    async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        session = Pop3Session(store, timeout=timeout)
        try:
            await pump(session, reader, writer)
        except Exception:  # one broken session never stops the server
            log.exception("POP3 session failed")
        finally:
            session.connection_lost()

    return await asyncio.start_server(serve, host, port)
