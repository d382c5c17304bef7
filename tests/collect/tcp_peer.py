"""A real TCP peer in front of a served logger, for the tests of kept connections
(``keep_open``): it forwards bytes both ways and, on demand, closes a connection, resets
one in the middle of its next answer (RST), stalls its next answer, or takes one
connection at a time (a GPRS modem's TCP server: another is closed at once)."""

from __future__ import annotations

import asyncio
import contextlib
import socket
import struct


class Link:
    """One connection through the peer: the collector's side and the logger's."""

    def __init__(
        self,
        peer: Peer,
        down: tuple[asyncio.StreamReader, asyncio.StreamWriter],
        up: tuple[asyncio.StreamReader, asyncio.StreamWriter],
    ) -> None:
        self.peer = peer
        self.down = down
        self.up = up
        #: Bytes of the answers to pass before a reset (None: no reset armed).
        self.reset_after: int | None = None
        self.stalled = False
        self.closed = False
        self.tasks = [
            asyncio.create_task(self._pump(down[0], up[1], answers=False)),
            asyncio.create_task(self._pump(up[0], down[1], answers=True)),
        ]

    async def _pump(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, answers: bool
    ) -> None:
        with contextlib.suppress(OSError, asyncio.CancelledError):
            while not self.closed:
                data = await reader.read(65536)
                if not data:
                    break
                if answers and self.stalled:
                    continue  # the answer never comes: the collector's timeout
                if answers and self.reset_after is not None:
                    if self.reset_after < len(data):
                        writer.write(data[: self.reset_after])
                        with contextlib.suppress(OSError):
                            await writer.drain()
                        self.reset()
                        return
                    self.reset_after -= len(data)  # counts down through the answers
                writer.write(data)
                await writer.drain()
        self.close()

    def close(self) -> None:
        """Close both sides now (FIN to the collector)."""
        if self.closed:
            return
        self.closed = True
        self.peer.links.discard(self)
        self.down[1].close()
        self.up[1].close()

    def reset(self) -> None:
        """Abort the collector's side with an RST (SO_LINGER 0), close the logger's."""
        sock = self.down[1].get_extra_info("socket")
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        self.close()


class Peer:
    """A listening TCP peer on a free loopback port forwarding to ``target``."""

    def __init__(self, target: int, *, one_at_a_time: bool = False) -> None:
        self.target = target
        self.one_at_a_time = one_at_a_time
        self.links: set[Link] = set()
        self.accepted = 0
        self.refused = 0
        self.server: asyncio.Server | None = None
        self.port = 0

    @property
    def url(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    async def start(self) -> Peer:
        self.server = await asyncio.start_server(self._accept, "127.0.0.1", 0)
        self.port = self.server.sockets[0].getsockname()[1]
        return self

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self.one_at_a_time and self.links:
            self.refused += 1
            writer.close()
            return
        up = await asyncio.open_connection("127.0.0.1", self.target)
        self.accepted += 1
        self.links.add(Link(self, (reader, writer), up))

    def close_all(self) -> None:
        for link in list(self.links):
            link.close()

    def arm(self, fault: str, at: int = 0) -> int:
        """``close``, ``reset`` (after ``at`` bytes of the next answer) or ``stall`` every
        open connection; how many it touched."""
        links = list(self.links)
        for link in links:
            if fault == "close":
                link.close()
            elif fault == "reset":
                link.reset_after = at
            else:
                link.stalled = True
        return len(links)

    async def stop(self) -> None:
        self.close_all()
        if self.server is not None:
            self.server.close()
            await self.server.wait_closed()
