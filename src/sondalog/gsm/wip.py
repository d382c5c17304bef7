"""Wavecom WIPsoft GPRS and TCP commands (gsm.md §2, manual §6.11.5.2.4).

Syntax and answers follow Sierra Wireless/Wavecom "WIP AT Commands User Guide, WIPsoft 5.41"
(WM_DEV_OAT_UGD_076 rev. 009, §4.2 ``+WIPBR``, §5 ``+WIPCREATE``/``+WIPCLOSE``, §6
``+WIPDATA``) and Multi-Tech's "IP Connectivity AT Commands" (S000437E, WIPsoft 3.11):

- ``AT+WIPCFG=1`` starts the IP stack, ``=0`` stops it (``+CME ERROR: 844`` when already
  started).
- ``AT+WIPBR=1,6`` opens the GPRS bearer, ``AT+WIPBR=2,6,<opt>,<value>`` sets an option
  (0 login, 1 password, 11 APN), ``AT+WIPBR=3,6,<opt>`` reads one (15: the modem's IP),
  ``AT+WIPBR=4,6,0`` starts it (``OK`` once attached; ``+CME ERROR: 812`` without GPRS
  service), ``AT+WIPBR=5,6`` stops, ``AT+WIPBR=0,6`` closes it; ``AT+WIPBR?`` ->
  ``+WIPBR: 6,<started>``.
- ``AT+WIPCREATE=2,<idx>,"<host>",<port>`` -> ``OK`` then ``+WIPREADY: 2,<idx>`` (or
  ``+WIPERROR: 2,<idx>,<code>``); ``AT+WIPCREATE=3,<idx>,<port>,<from>,<to>`` listens and
  announces each connection ``+WIPACCEPT: <idx>,<client idx>``.
- ``AT+WIPDATA=2,<idx>,1`` -> ``CONNECT``: continuous mode, bytes pass through until ``+++``
  (1 s guard times) -> ``OK``. Data arriving in command mode is announced
  ``+WIPDATA: 2,<idx>,<bytes>`` and kept for the next ``AT+WIPDATA``.
- The peer closing: ``+WIPPEERCLOSE: 2,<idx>`` in command mode; in data mode
  ``SHUTDOWN`` first, the URC after ``+++``.
- ``AT+WIPCLOSE=<proto>,<idx>`` closes a socket (2) or a server (3).
"""

from __future__ import annotations

from sondalog.gsm import events as ev
from sondalog.gsm.at_modem import AtModem, Handler, Server, Socket, WipState
from sondalog.gsm.atline import READ, TEST, AtCommand, AtSyntaxError, CmeError, Finish

HANDLERS: dict[str, Handler] = {}

GPRS_BEARER = 6
TCP_CLIENT = 2
TCP_SERVER = 3
MAX_SOCKETS = 8
MAX_SERVERS = 4

# WIPsoft error codes (WIPsoft 5.41 §12 "error codes").
BAD_OPTION = 800
STACK_STATE = 803
BEARER_NOT_AVAILABLE = 805
GPRS_FAILURE = 812
BAD_INDEX = 830
BAD_STATE = 831
BAD_PORT = 832
NOT_IMPLEMENTED = 834
BAD_PROTOCOL = 837
ALREADY_ACTIVE = 840
HOST_UNREACHABLE = 842
STACK_STARTED = 844


def _ints(cmd: AtCommand, minimum: int) -> list[int]:
    values = cmd.ints()
    if len(values) < minimum or any(v is None for v in values[:minimum]):
        raise AtSyntaxError("missing WIPsoft parameter")
    return [v if v is not None else 0 for v in values]


def wipcfg(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind in (READ, TEST):
        return []
    (mode,) = _ints(cmd, 1)[:1]
    if mode == 1:
        if m.wip.stack:
            raise CmeError(STACK_STARTED)
        m.wip.stack = True
    elif mode == 0:
        drop_all(m)
        m.wip.stack = False
        m.wip.bearer_open = False
    else:
        raise CmeError(BAD_OPTION)
    return []


def wipbr(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    w = m.wip
    if cmd.kind == READ:
        return [f"+WIPBR: {GPRS_BEARER},{int(w.started)}"] if w.bearer_open else []
    if cmd.kind == TEST:
        return []
    if not w.stack:
        raise CmeError(STACK_STATE)
    values = cmd.params()
    if len(values) < 2 or not values[0].isdigit() or not values[1].isdigit():
        raise AtSyntaxError("AT+WIPBR=<cmd>,<bid>")
    action, bid = int(values[0]), int(values[1])
    if bid != GPRS_BEARER:
        raise CmeError(BEARER_NOT_AVAILABLE)
    if action == 1:
        w.bearer_open = True
        return []
    if not w.bearer_open:
        raise CmeError(BAD_STATE)
    if action == 2:
        if len(values) < 4 or not values[2].isdigit():
            raise AtSyntaxError("AT+WIPBR=2,6,<opt>,<value>")
        w.options[int(values[2])] = values[3]
        return []
    if action == 3:
        if len(values) < 3 or not values[2].isdigit():
            raise AtSyntaxError("AT+WIPBR=3,6,<opt>")
        option = int(values[2])
        value = w.options.get(option, "")
        if option == 15:
            value = "10.0.0.1" if w.started else "0.0.0.0"
        return [f'+WIPBR: {GPRS_BEARER},{option},"{value}"']
    if action == 4:
        if w.started:
            raise CmeError(BAD_STATE)
        if not m.registered:
            raise CmeError(GPRS_FAILURE)
        w.started = True
        m.effect(ev.Attach(w.options.get(11, ""), w.options.get(0, "")))
        return []
    if action in (0, 5):
        _stop_bearer(m)
        if action == 0:
            w.bearer_open = False
        return []
    raise CmeError(BAD_OPTION)


def _stop_bearer(m: AtModem) -> None:
    w = m.wip
    for socket in list(w.sockets.values()):
        m.effect(ev.TcpClose(socket.handle))
    for server in w.servers.values():
        m.effect(ev.TcpUnlisten(server.port))
    w.sockets.clear()
    w.servers.clear()
    if w.started:
        w.started = False
        m.effect(ev.Detach())


def drop_all(m: AtModem) -> None:
    """Radio off, coverage lost, stack stopped: every socket and the bearer go down."""
    if m.mode == "data" and m.data_target is not None:
        m.leave_data_mode()
        m.final("NO CARRIER")
    _stop_bearer(m)


def wipcreate(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    w = m.wip
    if cmd.kind in (READ, TEST):
        return []
    params = cmd.params()
    if len(params) < 3 or not params[0].isdigit() or not params[1].isdigit():
        raise AtSyntaxError("AT+WIPCREATE=<proto>,<idx>,...")
    proto, index = int(params[0]), int(params[1])
    if not w.started:
        raise CmeError(STACK_STATE)
    if proto == TCP_CLIENT:
        if len(params) != 4 or not params[3].isdigit():
            raise AtSyntaxError('AT+WIPCREATE=2,<idx>,"<host>",<port>')
        if not 1 <= index <= MAX_SOCKETS:
            raise CmeError(BAD_INDEX)
        if index in w.sockets or _reserved(w, index):
            raise CmeError(ALREADY_ACTIVE)
        port = int(params[3])
        if not 1 <= port <= 65535:
            raise CmeError(BAD_PORT)
        handle = w.next_handle
        w.next_handle += 1
        w.sockets[index] = Socket(handle, index)
        m.effect(ev.TcpOpen(handle, params[2], port))
        return []
    if proto == TCP_SERVER:
        if len(params) != 5 or not all(p.isdigit() for p in params[2:]):
            raise AtSyntaxError("AT+WIPCREATE=3,<idx>,<port>,<from>,<to>")
        port, first, last = (int(p) for p in params[2:])
        if not 1 <= index <= MAX_SERVERS or not 1 <= first <= last <= MAX_SOCKETS:
            raise CmeError(BAD_INDEX)
        if not 1 <= port <= 65535:
            raise CmeError(BAD_PORT)
        if index in w.servers:
            raise CmeError(ALREADY_ACTIVE)
        w.servers[index] = Server(port, first, last)
        m.effect(ev.TcpListen(port))
        return []
    if proto in (1, 4, 5, 6):
        raise CmeError(NOT_IMPLEMENTED)
    raise CmeError(BAD_PROTOCOL)


def _reserved(w: WipState, index: int) -> bool:
    return any(s.first <= index <= s.last for s in w.servers.values())


def wipdata(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    if cmd.kind in (READ, TEST):
        return []
    values = _ints(cmd, 3)
    proto, index, mode = values[:3]
    if proto != TCP_CLIENT:
        raise CmeError(NOT_IMPLEMENTED if proto == 1 else BAD_PROTOCOL)
    socket = m.wip.sockets.get(index)
    if socket is None:
        raise CmeError(BAD_INDEX)
    if not socket.ready or mode not in (1, 2):
        raise CmeError(BAD_STATE)
    m.final("CONNECT")
    m.enter_data_mode(socket.handle, now)
    m.emit(bytes(socket.held))
    socket.held.clear()
    if socket.peer_closed:
        m.emit(b"\r\nSHUTDOWN\r\n")
    raise Finish(None)


def wipclose(m: AtModem, cmd: AtCommand, now: float) -> list[str]:
    w = m.wip
    if cmd.kind in (READ, TEST):
        return []
    proto, index = _ints(cmd, 2)[:2]
    if proto == TCP_CLIENT:
        socket = w.sockets.pop(index, None)
        if socket is None:
            raise CmeError(BAD_INDEX)
        if not socket.peer_closed:
            m.effect(ev.TcpClose(socket.handle))
        return []
    if proto == TCP_SERVER:
        server = w.servers.pop(index, None)
        if server is None:
            raise CmeError(BAD_INDEX)
        m.effect(ev.TcpUnlisten(server.port))
        return []
    raise CmeError(BAD_PROTOCOL)


def send(m: AtModem, handle: int, data: bytes) -> None:
    """Bytes from the DTE in continuous mode on socket ``handle``."""
    socket = m.wip.by_handle(handle)
    if socket is not None and socket.ready and not socket.peer_closed:
        m.effect(ev.TcpSend(data, handle))


def network_event(m: AtModem, event: ev.Event, now: float) -> None:
    w = m.wip
    if isinstance(event, ev.TcpIncoming):
        _accept(m, event)
        return
    handle = getattr(event, "handle", None)
    socket = w.by_handle(handle) if handle is not None else None
    if socket is None:
        if isinstance(event, ev.TcpData | ev.TcpConnected) and handle is not None:
            m.effect(ev.TcpClose(handle))
        return
    if isinstance(event, ev.TcpConnected):
        socket.ready = True
        m.urc(f"+WIPREADY: {TCP_CLIENT},{socket.index}")
    elif isinstance(event, ev.TcpFailed):
        del w.sockets[socket.index]
        m.urc(f"+WIPERROR: {TCP_CLIENT},{socket.index},{event.code}")
    elif isinstance(event, ev.TcpData):
        if m.mode == "data" and m.data_target == socket.handle:
            m.emit(event.data)
        else:
            first = not socket.held
            socket.held += event.data
            if first:
                m.urc(f"+WIPDATA: {TCP_CLIENT},{socket.index},{len(socket.held)}")
    elif isinstance(event, ev.TcpClosed):
        socket.peer_closed = True
        if m.mode == "data" and m.data_target == socket.handle:
            m.emit(b"\r\nSHUTDOWN\r\n")
            w.shutdown_pending.add(socket.index)
        else:
            m.urc(f"+WIPPEERCLOSE: {TCP_CLIENT},{socket.index}")


def after_escape(m: AtModem) -> None:
    """Back in command mode after ``+++``: report peers that closed meanwhile."""
    for index in sorted(m.wip.shutdown_pending):
        m.urc(f"+WIPPEERCLOSE: {TCP_CLIENT},{index}")
    m.wip.shutdown_pending.clear()


def _accept(m: AtModem, event: ev.TcpIncoming) -> None:
    w = m.wip
    for server_index, server in sorted(w.servers.items()):
        if server.port != event.port:
            continue
        for index in range(server.first, server.last + 1):
            if index not in w.sockets:
                w.sockets[index] = Socket(event.handle, index, ready=True)
                m.urc(f"+WIPACCEPT: {server_index},{index}")
                return
    m.effect(ev.TcpClose(event.handle))


HANDLERS.update(
    {"+WIPCFG": wipcfg, "+WIPBR": wipbr, "+WIPCREATE": wipcreate}
    | {"+WIPDATA": wipdata, "+WIPCLOSE": wipclose}
)
