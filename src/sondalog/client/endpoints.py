"""Where a host tool connects to: a TCP address, a serial port or a served logger's pty.

:func:`parse_url` turns a URL into an :class:`Endpoint`; an endpoint opens an asyncio
connection with a given protocol factory (``loop.create_connection`` for TCP,
``serial_asyncio_fast.create_serial_connection`` for serial ports), so the client does not
care which it talks through.

- ``tcp://HOST:PORT`` (IPv6 as ``tcp://[::1]:10001``)
- ``serial:///dev/ttyUSB0?baud=9600``: a serial port, 8N1, no flow control in the driver
  (XON/XOFF are the module's own, §6.11.1); ``baud`` defaults to 9600, the factory
  ``com speed`` (§6.11.2). The pty symlink of ``sondalog logger serve --pty PATH`` is opened
  the same way: ``serial:///tmp/ala1?baud=9600``. ``pty://`` is accepted as a synonym, and a
  relative path may be written ``serial:ala1``.
- ``gsm://API-HOST:PORT/NUMBER?from=PHONE``: a data call from PHONE to the modem NUMBER of a
  served GSM network, placed through its HTTP API (:mod:`sondalog.client.phone`, docs/gsm.md).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, TypeVar
from urllib.parse import parse_qs, unquote, urlsplit

from sondalog.client.phone import parse_gsm_url
from sondalog.io.serial_ports import serial_8n1

_P = TypeVar("_P", bound=asyncio.Protocol)

#: URL schemes that :func:`parse_url` understands.
SCHEMES = ("tcp", "serial", "pty", "gsm")
#: §6.11.2: the factory ``com speed``.
DEFAULT_BAUD = 9600


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


@dataclass(frozen=True)
class SerialEndpoint:
    """A logger on a serial port, or on the pty of a served logger (8N1 at ``baud``)."""

    device: str
    baud: int = DEFAULT_BAUD

    async def connect(self, factory: Callable[[], _P]) -> tuple[asyncio.BaseTransport, _P]:
        import serial_asyncio_fast  # imported here: only serial endpoints need it

        loop = asyncio.get_running_loop()
        transport, protocol = await serial_asyncio_fast.create_serial_connection(
            loop,
            factory,
            self.device,
            baudrate=self.baud,
            **serial_8n1(),
        )
        await asyncio.sleep(0)  # connection_made() is scheduled with call_soon: let it run
        return transport, protocol  # type: ignore[return-value]

    def __str__(self) -> str:
        return f"serial://{self.device}?baud={self.baud}"


def _serial_endpoint(url: str, path: str, query: str) -> SerialEndpoint:
    device = unquote(path)
    if not device or device == "/":
        raise ValueError(f"expected serial:///DEVICE?baud=N, got {url!r}")
    try:
        options = parse_qs(query, keep_blank_values=True, strict_parsing=bool(query))
    except ValueError as exc:
        raise ValueError(f"bad query in {url!r}") from exc
    unknown = set(options) - {"baud"}
    if unknown:
        raise ValueError(f"unknown option {sorted(unknown)[0]!r} in {url!r} (only baud)")
    baud_text = options.get("baud", [str(DEFAULT_BAUD)])[-1]
    if not baud_text.isdigit() or int(baud_text) <= 0:
        raise ValueError(f"baud must be a positive number, got {baud_text!r}")
    return SerialEndpoint(device, int(baud_text))


def parse_url(url: str) -> Endpoint:
    """A URL (see the module docstring) -> an :class:`Endpoint`.

    Raises :class:`ValueError` with a message fit for a user.
    """
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in SCHEMES:
        known = ", ".join(f"{s}://" for s in SCHEMES)
        raise ValueError(f"unsupported URL {url!r}: expected one of {known}")
    if scheme in ("serial", "pty"):
        if parts.netloc:
            raise ValueError(f"expected serial:///DEVICE (three slashes), got {url!r}")
        return _serial_endpoint(url, parts.path, parts.query)
    if scheme == "gsm":
        return parse_gsm_url(url)
    try:
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise ValueError(f"bad port in {url!r}") from exc
    if not host or port is None or parts.path not in ("", "/") or parts.query:
        raise ValueError(f"expected tcp://HOST:PORT, got {url!r}")
    return TcpEndpoint(host, port)
