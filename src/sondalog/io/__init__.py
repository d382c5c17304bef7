"""Transports: thin asyncio adapters between byte streams and the pure cores (DESIGN.md point 1).

:class:`EngineHost` owns one ALA1 :class:`~sondalog.ala1.Engine` and its clock and runs the
engine's timers; :func:`serve_tcp` attaches TCP connections to it, one line per connection
(§6.11.5.2.4: the ALA GPRS modem's TCP server on port 10001).
"""

from sondalog.io.host import EngineHost, Sink
from sondalog.io.tcp import DEFAULT_PORT, TcpServer, serve_tcp

__all__ = ["DEFAULT_PORT", "EngineHost", "Sink", "TcpServer", "serve_tcp"]
