"""Where a host tool connects to: ``tcp://HOST:PORT`` today, serial and pty URLs later.

:func:`parse_url` turns a URL into an :class:`Endpoint`; an endpoint opens an asyncio
connection with a given protocol factory. A serial endpoint will do the same with
``serial_asyncio_fast.create_serial_connection``, so the client does not change when it
arrives.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, TypeVar
from urllib.parse import urlsplit

_P = TypeVar("_P", bound=asyncio.Protocol)

#: URL schemes that :func:`parse_url` understands (``serial://``, ``pty://`` come later).
SCHEMES = ("tcp",)


class Endpoint(Protocol):
    """Something a client can open a byte stream to."""

    async def connect(self, factory: Callable[[], _P]) -> tuple[asyncio.BaseTransport, _P]:
        """Open the connection; returns the transport and the protocol ``factory`` built."""
        ...


@dataclass(frozen=True)
class TcpEndpoint:
    """A logger served over TCP (§6.11.5.2.4: the GPRS modem's TCP server)."""

    host: str
    port: int

    async def connect(self, factory: Callable[[], _P]) -> tuple[asyncio.BaseTransport, _P]:
        loop = asyncio.get_running_loop()
        return await loop.create_connection(factory, self.host, self.port)

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"tcp://{host}:{self.port}"


def parse_url(url: str) -> Endpoint:
    """``tcp://HOST:PORT`` (IPv6 as ``tcp://[::1]:10001``) -> an :class:`Endpoint`.

    Raises :class:`ValueError` with a message fit for a user.
    """
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in SCHEMES:
        known = ", ".join(f"{s}://" for s in SCHEMES)
        raise ValueError(f"unsupported URL {url!r}: expected one of {known}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise ValueError(f"bad port in {url!r}") from exc
    if not host or port is None or parts.path not in ("", "/") or parts.query:
        raise ValueError(f"expected tcp://HOST:PORT, got {url!r}")
    return TcpEndpoint(host, port)
