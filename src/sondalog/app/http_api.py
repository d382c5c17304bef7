"""An HTTP JSON API served by uvicorn on a socket bound here: the GSM network's API
(:mod:`sondalog.app.gsm_api`) and the control API (:mod:`sondalog.app.control_api`) share it.

The socket is bound before uvicorn starts, so a port in use is an ``OSError`` at once and
port 0 takes a free one (:attr:`HttpApi.address` says which). It names ``IPPROTO_TCP``:
asyncio sets ``TCP_NODELAY`` only on sockets that say so, and without it a keep-alive client
waits 40 ms for a delayed ACK on every answer written in two parts.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import Iterator

import uvicorn
from starlette.applications import Starlette


class _Server(uvicorn.Server):
    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield  # the serve loop owns SIGINT and SIGTERM


class HttpApi:
    """uvicorn serving ``app`` on ``host:port`` (errors binding raise OSError)."""

    #: What a failed start says (a subclass names its API).
    what = "the HTTP API"

    def __init__(self, app: Starlette, host: str, port: int) -> None:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self.sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.sock.bind((host, port))
        except OSError:
            self.sock.close()
            raise
        self.sock.listen(128)
        config = uvicorn.Config(app, log_level="warning", lifespan="off", access_log=False)
        self.server = _Server(config)
        self.task: asyncio.Task[None] | None = None

    @property
    def address(self) -> tuple[str, int]:
        name = self.sock.getsockname()
        return str(name[0]), int(name[1])

    async def start(self) -> None:
        self.task = asyncio.get_running_loop().create_task(self.server.serve([self.sock]))
        while not self.server.started:
            if self.task.done():
                self.task.result()
                raise OSError(f"{self.what} did not start")
            await asyncio.sleep(0.01)

    async def stop(self) -> None:
        self.server.should_exit = True
        if self.task is not None:
            with contextlib.suppress(Exception):
                await self.task
        self.sock.close()
