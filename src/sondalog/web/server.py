"""Running the dashboard inside the caller's event loop (the collector's).

:func:`serve` binds the socket itself (so a busy port is an ``OSError`` here, not uvicorn's
``sys.exit``), leaves the process's signal handlers alone (the caller owns them) and stops
cleanly when its task is cancelled. It listens on loopback only, unless told
``allow_remote=True`` *and* given a token.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import Callable, Generator

import uvicorn
from starlette.applications import Starlette

from sondalog.config import ConfigError, is_loopback

from .app import Settings, check_token


class _Server(uvicorn.Server):
    @contextlib.contextmanager
    def capture_signals(self) -> Generator[None, None, None]:
        yield  # the caller's loop owns SIGINT and SIGTERM


def check_listen(
    host: str, *, allow_remote: bool, token: str | None, field: str = "listen"
) -> None:
    """Raise :class:`~sondalog.config.ConfigError` (of ``field``) unless listening on ``host``
    is allowed."""
    if is_loopback(host):
        return
    if not allow_remote:
        raise ConfigError(
            None,
            field,
            f"refusing to listen on {host}: the dashboard listens on loopback (127.0.0.1) "
            "unless remote access is allowed explicitly and a token is set",
        )
    if not token:
        raise ConfigError(
            None,
            field,
            f"refusing to listen on {host} without a token: anyone on the network could "
            "read the data; set a token (then requests need 'Authorization: Bearer <token>')",
        )


def bind(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: any free port)."""
    name = "127.0.0.1" if host == "localhost" else host.strip("[]")
    family = socket.AF_INET6 if ":" in name else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((name, port))
        sock.listen(128)
        sock.setblocking(False)
    except OSError:
        sock.close()
        raise
    return sock


async def serve(
    app: Starlette,
    host: str = "127.0.0.1",
    port: int = 8080,
    *,
    allow_remote: bool = False,
    token: str | None = None,
    on_listen: Callable[[str, int], None] | None = None,
) -> None:
    """Serve ``app`` on ``host:port`` until cancelled (run it as a task in your loop).

    ``token`` (or the one given to ``create_app``) is then required on every request.
    ``on_listen(host, port)`` is called once the socket listens (useful with port 0).
    """
    settings: Settings = app.state.settings
    if token is not None:
        settings.token = check_token(token)
    check_listen(host, allow_remote=allow_remote, token=settings.token)
    settings.stopping = False
    sock = bind(host, port)
    bound = sock.getsockname()
    config = uvicorn.Config(
        app,
        lifespan="off",
        log_level="warning",
        access_log=False,
        timeout_graceful_shutdown=1,
        proxy_headers=False,
    )
    server = _Server(config)
    inner = asyncio.ensure_future(server.serve(sockets=[sock]))
    try:
        if on_listen is not None:
            while not server.started and not inner.done():
                await asyncio.sleep(0.01)
            if server.started:
                on_listen(str(bound[0]), int(bound[1]))
        await asyncio.shield(inner)
    except asyncio.CancelledError:
        settings.stopping = True  # live streams end at their next poll
        server.should_exit = True
        with contextlib.suppress(asyncio.CancelledError):
            await inner
        raise
    finally:
        sock.close()
        # the alarm store's connection (a PostgreSQL one is kept), once no request uses it,
        # and the readings' kept server connections
        await asyncio.shield(asyncio.to_thread(settings.alarms.close))
        await asyncio.shield(asyncio.to_thread(settings.readings.shutdown))
