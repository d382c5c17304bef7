"""Host side: talk to ALA1 loggers (DESIGN.md point 7: the one front door of the host side).

- :class:`Ala1Client` (asyncio) and :class:`Client` (blocking) send command lines and return
  parsed :class:`Response` objects, adding ``check`` and verifying ``sum``/``crcsum`` (§8).
- :func:`parse_url` turns ``tcp://HOST:PORT`` or ``serial:///dev/ttyX?baud=N`` into an endpoint.
- :class:`BusMaster` (asyncio) and :class:`BlockingBusMaster` are the master of an HCTMPS1
  RS-485 bus (docs/hctmps1.md).
- :mod:`sondalog.client.tables` and :mod:`sondalog.client.transfer`: conversion tables and
  XMODEM transfers with a logger (§6.16, §10).
"""

from sondalog.client.ala1 import Ala1Client, Client
from sondalog.client.ala1_codec import (
    ChecksumError,
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
from sondalog.client.bus import BlockingBusMaster, BusMaster, DataFrame
from sondalog.client.bus_errors import NoReply, UnexpectedReply
from sondalog.client.bus_links import BusLink, BusUrlError, parse_bus_url
from sondalog.client.endpoints import Endpoint, SerialEndpoint, TcpEndpoint, parse_url

__all__ = [
    "Ala1Client",
    "BlockingBusMaster",
    "BusLink",
    "BusMaster",
    "BusUrlError",
    "ChecksumError",
    "Client",
    "ClientError",
    "CommandFailed",
    "ConnectionLost",
    "CrcMismatch",
    "DataFrame",
    "Endpoint",
    "IncompleteAnswer",
    "NoAnswer",
    "NoReply",
    "Request",
    "Response",
    "SerialEndpoint",
    "Status",
    "SumMismatch",
    "TcpEndpoint",
    "UnexpectedReply",
    "parse_bus_url",
    "parse_url",
    "with_check",
]
