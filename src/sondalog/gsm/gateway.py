"""The network's IP gateway: GPRS-attached modems reach real TCP servers, and a modem's
listening port (10001, manual §3.4.6.4) is published on a host port (gsm.md §1).

Pure: the gateway says ``Connect``/``Send``/``Close``/``Listen``/``Unlisten`` as effects and
takes ``Connected``/``ConnectFailed``/``Received``/``Closed``/``Accepted`` events from the
runtime, which owns the sockets. Host names resolve through a table (``smtp.example.net`` ->
``127.0.0.1``); a dotted IPv4 address stands for itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.gsm import events as ev

HOST_UNREACHABLE = 842


# -- effects toward the runtime ----------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Connect:
    conn: int
    host: str
    port: int


@dataclass(frozen=True, slots=True)
class Send:
    conn: int
    data: bytes


@dataclass(frozen=True, slots=True)
class Close:
    conn: int


@dataclass(frozen=True, slots=True)
class Listen:
    """Listen on ``host:port`` (a host port) for the modem port behind ``listener``."""

    listener: int
    host: str
    port: int


@dataclass(frozen=True, slots=True)
class Unlisten:
    listener: int


IpEffect = Connect | Send | Close | Listen | Unlisten


# -- events from the runtime -------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Connected:
    conn: int


@dataclass(frozen=True, slots=True)
class ConnectFailed:
    conn: int


@dataclass(frozen=True, slots=True)
class Received:
    conn: int
    data: bytes


@dataclass(frozen=True, slots=True)
class Closed:
    conn: int


@dataclass(frozen=True, slots=True)
class Accepted:
    """The runtime accepted connection ``conn`` on ``listener``'s host port."""

    listener: int
    conn: int


IpEvent = Connected | ConnectFailed | Received | Closed | Accepted


@dataclass(frozen=True, slots=True)
class ModemEvent:
    """An event for the modem of subscriber ``number``."""

    number: str
    event: ev.Event


#: What the gateway says: events for modems, socket effects for the runtime.
GatewayOutput = ModemEvent | IpEffect


def _is_ipv4(host: str) -> bool:
    parts = host.split(".")
    return len(parts) == 4 and all(p.isdigit() and int(p) < 256 for p in parts)


@dataclass(slots=True)
class IpGateway:
    """Connections and listeners of every attached modem."""

    hosts: dict[str, str] = field(default_factory=dict)
    listen_host: str = "127.0.0.1"
    #: (number, modem port) -> host port
    published: dict[tuple[str, int], int] = field(default_factory=dict)
    _conns: dict[int, tuple[str, int]] = field(default_factory=dict)  # conn -> (number, handle)
    _listeners: dict[int, tuple[str, int]] = field(default_factory=dict)  # id -> (number, port)
    _next: int = 1

    def resolve(self, host: str) -> str | None:
        if _is_ipv4(host):
            return host
        return self.hosts.get(host.lower())

    def publish(self, number: str, modem_port: int, host_port: int) -> None:
        self.published[(number, modem_port)] = host_port

    def host_port(self, number: str, modem_port: int) -> int | None:
        return self.published.get((number, modem_port))

    def _id(self) -> int:
        self._next += 1
        return self._next - 1

    def _conn_of(self, number: str, handle: int) -> int | None:
        return next((c for c, key in self._conns.items() if key == (number, handle)), None)

    # -- from modems ---------------------------------------------------------------------
    def open(self, number: str, handle: int, host: str, port: int) -> list[GatewayOutput]:
        ip = self.resolve(host)
        if ip is None:
            return [ModemEvent(number, ev.TcpFailed(handle, HOST_UNREACHABLE))]
        conn = self._id()
        self._conns[conn] = (number, handle)
        return [Connect(conn, ip, port)]

    def send(self, number: str, handle: int, data: bytes) -> list[GatewayOutput]:
        conn = self._conn_of(number, handle)
        return [] if conn is None else [Send(conn, data)]

    def close(self, number: str, handle: int) -> list[GatewayOutput]:
        conn = self._conn_of(number, handle)
        if conn is None:
            return []
        del self._conns[conn]
        return [Close(conn)]

    def listen(self, number: str, port: int) -> list[GatewayOutput]:
        host_port = self.published.get((number, port))
        if host_port is None or (number, port) in self._listeners.values():
            return []
        listener = self._id()
        self._listeners[listener] = (number, port)
        return [Listen(listener, self.listen_host, host_port)]

    def unlisten(self, number: str, port: int) -> list[GatewayOutput]:
        found = [lid for lid, key in self._listeners.items() if key == (number, port)]
        for lid in found:
            del self._listeners[lid]
        return [Unlisten(lid) for lid in found]

    def drop(self, number: str) -> list[GatewayOutput]:
        """The modem detached or lost coverage: close everything it had."""
        out: list[GatewayOutput] = []
        for conn in [c for c, (n, _) in self._conns.items() if n == number]:
            del self._conns[conn]
            out.append(Close(conn))
        for lid in [lid for lid, (n, _) in self._listeners.items() if n == number]:
            del self._listeners[lid]
            out.append(Unlisten(lid))
        return out

    def listening(self, number: str) -> list[int]:
        """Modem ports of ``number`` published and listening now."""
        return sorted(p for n, p in self._listeners.values() if n == number)

    # -- from the runtime ----------------------------------------------------------------
    def ip_event(self, event: IpEvent) -> list[GatewayOutput]:
        if isinstance(event, Accepted):
            key = self._listeners.get(event.listener)
            if key is None:
                return [Close(event.conn)]
            number, port = key
            handle = ev.INCOMING_HANDLES + event.conn
            self._conns[event.conn] = (number, handle)
            return [ModemEvent(number, ev.TcpIncoming(port, handle))]
        owner = self._conns.get(event.conn)
        if owner is None:
            return [] if isinstance(event, Closed | ConnectFailed) else [Close(event.conn)]
        number, handle = owner
        if isinstance(event, Connected):
            return [ModemEvent(number, ev.TcpConnected(handle))]
        if isinstance(event, Received):
            return [ModemEvent(number, ev.TcpData(handle, event.data))]
        del self._conns[event.conn]
        if isinstance(event, ConnectFailed):
            return [ModemEvent(number, ev.TcpFailed(handle, HOST_UNREACHABLE))]
        return [ModemEvent(number, ev.TcpClosed(handle))]
