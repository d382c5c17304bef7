"""E-mail through the modem's WIPsoft TCP sockets (gsm.md §2, §4; manual §3.4.6.2, §6.13).

The logger speaks SMTP and POP3 itself (:mod:`sondalog.protocol.smtp_client`,
:mod:`sondalog.protocol.pop3_client`) over a WIPsoft TCP client socket in continuous mode
(``AT+WIPDATA=2,1,1``): the GPRS bearer is started with ``com network apn address``, the
socket connects to the server's host name (the network resolves it), the client's bytes pass
in data mode, ``+++`` ends it, ``AT+WIPCLOSE`` closes the socket. After each e-mail it sent,
the logger checks its command mailbox once (§6.11.6.4).
"""

from __future__ import annotations

from collections.abc import Generator
from datetime import UTC, datetime

from sondalog.ala1.modem.atio import (
    CONNECT_FINALS,
    At,
    PendingReply,
    Recv,
    Request,
    Urc,
    Write,
    as_reply,
    at,
)
from sondalog.ala1.modem.host import Driver
from sondalog.ala1.modem.session import (
    NO_CARRIER,
    SHUTDOWN,
    EndMarker,
    back_in_command_mode,
    leave_data_mode,
)
from sondalog.ala1.modem.steps import execute, registered
from sondalog.protocol.mail_address import MailAddressError, parse_pop3_server, parse_smtp_server
from sondalog.protocol.mail_command import MailCommand, build_mail, parse_command_mail
from sondalog.protocol.pop3_client import Pop3Check
from sondalog.protocol.smtp_client import SmtpClient

SOCKET = 1
#: WIPsoft TCP server on port 10001 (wavecom42); its connections get sockets 5..8.
SERVER = 1
SERVER_SOCKETS = (5, 8)
COMMAND_PORT = 10001
BAD_STATE = 831  # WIPsoft: the bearer is in the wrong state (here: started already)
SOCKET_EXISTS = 840  # WIPsoft: the socket index is in use
MAIL_TIMEOUT = 60.0
DEFAULT_FROM = "ala1@localhost"


def gprs_up(d: Driver) -> Generator[Request, object, bool]:
    """Attach to GPRS (and listen on port 10001 in ``wavecom42``, §6.11.5.2.4)."""
    if not d.gprs:
        if not (yield from registered(d)):
            return False
        yield At("AT+WIPCFG=1")  # +CME ERROR: 844 (already started) is fine
        yield At("AT+WIPBR=1,6")
        apn = d.host.setting("com network apn address").replace('"', "")
        yield At(f'AT+WIPBR=2,6,11,"{apn}"')
        started = yield from at("AT+WIPBR=4,6,0", 60.0)
        # +CME ERROR: 831 after opening the bearer: it was started already (the driver had
        # forgotten it after setting the modem up again)
        d.gprs = started.ok or started.final == f"+CME ERROR: {BAD_STATE}"
        d.listening = False
    if d.gprs and not d.listening and d.host.setting("com device") == "WAVECOM42":
        first, last = SERVER_SOCKETS
        create = f"AT+WIPCREATE=3,{SERVER},{COMMAND_PORT},{first},{last}"
        d.listening = (yield from at(create)).ok
        if not d.listening:  # a server left from before: closed, made again
            yield At(f"AT+WIPCLOSE=3,{SERVER}")
            d.listening = (yield from at(create)).ok
    return d.gprs


def gprs_down(d: Driver) -> Generator[Request, object, None]:
    if d.listening:
        yield At(f"AT+WIPCLOSE=3,{SERVER}")
    yield At("AT+WIPBR=5,6")
    yield At("AT+WIPBR=0,6")
    yield At("AT+WIPCFG=0")
    d.gprs = d.listening = False


def tcp(
    d: Driver, host: str, port: int, client: SmtpClient | Pop3Check
) -> Generator[Request, object, None]:
    """Run ``client`` over a WIPsoft TCP socket to ``host:port``."""
    if not (yield from gprs_up(d)) or '"' in host:
        client.connection_failed("no GPRS connection")
        return
    create = f'AT+WIPCREATE=2,{SOCKET},"{host}",{port}'
    created = yield from at(create)
    if created.final == f"+CME ERROR: {SOCKET_EXISTS}":  # left from a session cut short
        yield At(f"AT+WIPCLOSE=2,{SOCKET}")
        created = yield from at(create)
    if not created.ok:
        d.gprs = d.listening = False  # the bearer went down under us: attach again next time
        client.connection_failed("socket refused")
        return
    ready = yield Urc((f"+WIPREADY: 2,{SOCKET}", f"+WIPERROR: 2,{SOCKET}"), MAIL_TIMEOUT)
    if not isinstance(ready, str) or not ready.startswith("+WIPREADY"):
        client.connection_failed(f"cannot connect to {host}:{port}")
        yield At(f"AT+WIPCLOSE=2,{SOCKET}")
        return
    connect = as_reply((yield At(f"AT+WIPDATA=2,{SOCKET},1", finals=CONNECT_FINALS)))
    if not connect.final.startswith("CONNECT"):
        client.connection_failed("no data mode")
        yield At(f"AT+WIPCLOSE=2,{SOCKET}")
        return
    client.start(d.now)
    # SHUTDOWN: the server closed; NO CARRIER: the modem lost its bearer (coverage) and is
    # back in command mode (gsm.md §7: no +++ then, and what followed is read as lines)
    end = EndMarker(SHUTDOWN, NO_CARRIER)
    while not client.wants_close:
        out = client.data_to_send()
        if out:
            yield Write(out)
        if client.wants_close:
            break
        data = yield Recv(client.deadline or d.now + MAIL_TIMEOUT)
        data, ended = end.cut(data if isinstance(data, bytes) else b"")
        if ended:  # the server closed the connection
            client.receive_data(data, d.now)
            client.receive_data(b"", d.now)
            break
        elif data:
            client.receive_data(data, d.now)
        else:
            client.handle_timeout(d.now)
    d.listing_due = True  # SMS that came during the GPRS session had no notice
    if end.found == NO_CARRIER:
        back_in_command_mode(d, end)
        d.gprs = d.listening = False
        yield At(f"AT+WIPCLOSE=2,{SOCKET}")
        return
    out = client.data_to_send()
    if out:
        yield Write(out)
    if (yield from leave_data_mode(d)):
        yield At(f"AT+WIPCLOSE=2,{SOCKET}")


def send_mail(
    d: Driver, address: str, server: str | None, subject: str, body: str
) -> Generator[Request, object, bool]:
    """Send one e-mail; when it went, check the command mailbox once (§6.11.6.4)."""
    try:
        smtp = parse_smtp_server(server or d.host.setting("com network smtp address"))
    except MailAddressError:
        return False
    sender = d.host.setting("email send from").strip() or DEFAULT_FROM
    date = datetime.fromtimestamp(d.now, UTC)
    message = build_mail(sender, address, subject, body, date=date)
    try:
        client = SmtpClient(
            sender, [address], message, user=smtp.user, password=smtp.password, timeout=MAIL_TIMEOUT
        )
    except ValueError:
        return False
    yield from tcp(d, smtp.host, smtp.port, client)
    sent = client.result is not None and client.result.sent
    if sent:
        yield from check_mailbox(d)
    return sent


def check_mailbox(d: Driver) -> Generator[Request, object, None]:
    """The oldest command e-mail: too big -> deleted unread; else read, run, answered."""
    spec = d.host.setting("com network pop3 address").strip()
    if not spec:
        return
    try:
        server = parse_pop3_server(spec)
        client = Pop3Check(
            server.user or "",
            server.password or "",
            max_size=int(d.host.setting("com network pop3 size")),
            time_limit=float(d.host.setting("com network pop3 time")),
            timeout=MAIL_TIMEOUT,
        )
    except (MailAddressError, ValueError):
        return
    yield from tcp(d, server.host, server.port, client)
    result = client.result
    if result is None or result.outcome != "mail" or result.message is None:
        return
    found = parse_command_mail(result.message, d.host.setting("sms command boundary"))
    if not isinstance(found, MailCommand):
        return
    answer = yield from execute(d, found.command)
    if answer:
        d.replies.append(PendingReply("email", found.reply_to, answer, d.now))
