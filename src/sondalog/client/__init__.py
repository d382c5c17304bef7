"""Host side: talk to ALA1 loggers (DESIGN.md point 7: the one front door of the host side).

- :class:`Ala1Client` (asyncio) and :class:`Client` (blocking) send command lines and return
  parsed :class:`Response` objects, adding ``check`` and verifying ``sum``/``crcsum`` (§8).
- :func:`parse_url` turns ``tcp://HOST:PORT`` into an endpoint.
"""

from sondalog.client.ala1 import (
    Ala1Client,
    ChecksumError,
    Client,
    ClientError,
    CommandFailed,
    ConnectionLost,
    CrcMismatch,
    IncompleteAnswer,
    NoAnswer,
    Request,
    Response,
    Status,
    SumMismatch,
    with_check,
)
from sondalog.client.endpoints import Endpoint, TcpEndpoint, parse_url

# bus master: sondalog.client.bus

__all__ = [
    "Ala1Client",
    "ChecksumError",
    "Client",
    "ClientError",
    "CommandFailed",
    "ConnectionLost",
    "CrcMismatch",
    "Endpoint",
    "IncompleteAnswer",
    "NoAnswer",
    "Request",
    "Response",
    "Status",
    "SumMismatch",
    "TcpEndpoint",
    "parse_url",
    "with_check",
]
