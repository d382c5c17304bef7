"""Connections kept open between a source's contacts (``keep_open = true``, issue 24).

A logger source with ``keep_open`` hands its connection back here after a contact that
ended well, and takes it again at its next contact instead of connecting. What is held is
bounded: one connection a source, at most :attr:`KeptConnections.limit` in all (beyond it a
contact closes its connection as without ``keep_open``), and nothing a peer sends while its
connection waits: an idle connection's transport is handed to :class:`_Idle`, which keeps no
byte and closes the connection at the first one (a peer that talks out of turn is no longer
trusted to answer in step). A connection the peer closed meanwhile is found closed when it
is taken, and a fresh one is made.

The retry of a contact that fails on a kept connection (once, on a fresh one) is the
source's (:class:`~sondalog.collect.sources.LoggerSource`): a contact resumes after the
cursor the store holds, so readings delivered before the failure are not read twice, and
none after it are lost.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import resource
from typing import cast

from sondalog.client import Ala1Client

log = logging.getLogger(__name__)

#: File descriptors left to everything else (the store, the sinks, the dashboard, new
#: connections of the other sources) when the limit follows ``RLIMIT_NOFILE``.
SPARE_FILES = 1024


def default_limit() -> int:
    """How many connections a collector keeps: its open-file limit less :data:`SPARE_FILES`
    (at least 0)."""
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return 1 << 20
    return max(0, soft - SPARE_FILES)


class _Idle(asyncio.Protocol):
    """The protocol of a connection between contacts: it keeps no byte. Any byte closes the
    connection (an answer out of turn); the close is passed to the client's own protocol,
    so its ``closed`` is true when the connection is taken again."""

    def __init__(self, inner: asyncio.Protocol, transport: asyncio.Transport) -> None:
        self.inner = inner
        self.transport = transport
        self.spoke = False

    def data_received(self, data: bytes) -> None:
        self.spoke = True
        self.transport.close()

    def eof_received(self) -> bool | None:
        return None  # the peer is done: close ours too

    def connection_lost(self, exc: Exception | None) -> None:
        self.inner.connection_lost(exc)


class KeptConnections:
    """The open connections of the ``keep_open`` sources between their contacts, by source
    name; at most ``limit`` of them."""

    def __init__(self, limit: int | None = None) -> None:
        self.limit = default_limit() if limit is None else limit
        self._held: dict[str, tuple[Ala1Client, _Idle]] = {}
        self._full_said = False
        #: Connections made for a contact, and contacts that used a kept one (for tests and
        #: the benchmark's report).
        self.opened = 0
        self.reused = 0

    def __len__(self) -> int:
        return len(self._held)

    def __contains__(self, name: str) -> bool:
        return name in self._held

    def take(self, name: str) -> Ala1Client | None:
        """The connection kept for ``name``, given back to its client; None when none is
        kept or the kept one was closed meanwhile (closed here)."""
        held = self._held.pop(name, None)
        if held is None:
            return None
        client, idle = held
        transport = idle.transport
        if idle.spoke or client.open_transport is None:
            transport.close()
            return None
        transport.set_protocol(idle.inner)
        self.reused += 1
        return client

    def keep(self, name: str, client: Ala1Client) -> bool:
        """Hold ``client``'s connection until ``name``'s next contact; False (and the
        connection closed) when it is closed already or :attr:`limit` are held."""
        transport = client.open_transport
        if transport is None:
            return False
        old = self._held.pop(name, None)
        if old is not None:  # not expected: a source takes its connection before a contact
            old[1].transport.close()
        if len(self._held) >= self.limit:
            if not self._full_said:
                log.warning(
                    "keep_open: %d connections held, the limit (open files less %d): "
                    "further contacts close theirs",
                    self.limit,
                    SPARE_FILES,
                )
                self._full_said = True
            transport.close()
            return False
        inner = cast(asyncio.Protocol, transport.get_protocol())
        idle = _Idle(inner, transport)
        transport.set_protocol(idle)
        self._held[name] = (client, idle)
        return True

    def drop(self, name: str) -> None:
        """Close the connection kept for ``name`` (its source stopped or was removed)."""
        held = self._held.pop(name, None)
        if held is not None:
            held[1].transport.close()

    def close(self) -> None:
        """Close every kept connection (the collector stops)."""
        for name in list(self._held):
            self.drop(name)


async def close_quietly(client: Ala1Client) -> None:
    """Close ``client``'s connection; a failing close changes nothing."""
    with contextlib.suppress(Exception):
        await client.close()
