"""Run the logger's pure SMTP and POP3 client cores over a real TCP connection.

The cores (:mod:`sondalog.protocol.smtp_client`, :mod:`sondalog.protocol.pop3_client`) do
not know their transport; here it is a plain asyncio TCP connection. The logger itself runs
the same cores through its modem's WIPsoft TCP socket instead.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence

from ...protocol.mail_address import MailServer
from ...protocol.pop3_client import Pop3Check, Pop3Result
from ...protocol.smtp_client import SmtpClient, SmtpResult
from .pump import pump


async def _run(core: SmtpClient | Pop3Check, server: MailServer, timeout: float) -> None:
    try:
        reader, writer = await asyncio.wait_for(
            asyncio.open_connection(server.host, server.port), timeout
        )
    except TimeoutError:
        core.connection_failed(f"cannot connect to {server.host}:{server.port}: timeout")
        return
    except OSError as exc:
        core.connection_failed(f"cannot connect to {server.host}:{server.port}: {exc}")
        return
    error = await pump(core, reader, writer)
    if error is not None:
        core.connection_failed(error)


async def send_mail(
    server: MailServer,
    sender: str,
    recipients: Sequence[str],
    message: bytes,
    *,
    helo_name: str = "ala1",
    timeout: float = 60.0,
) -> SmtpResult:
    """Send ``message`` through ``server`` (credentials from the spec, if any)."""
    client = SmtpClient(
        sender,
        list(recipients),
        message,
        helo_name=helo_name,
        user=server.user,
        password=server.password,
        timeout=timeout,
    )
    await _run(client, server, timeout)
    assert client.result is not None
    return client.result


async def check_mailbox(
    server: MailServer,
    *,
    max_size: int,
    time_limit: float,
    timeout: float = 60.0,
) -> Pop3Result:
    """One command-mailbox check (§6.11.6.4): take the oldest message, if any."""
    if server.user is None:
        raise ValueError("a POP3 mailbox needs user:password@")
    check = Pop3Check(
        server.user,
        server.password or "",
        max_size=max_size,
        time_limit=time_limit,
        timeout=timeout,
    )
    await _run(check, server, timeout)
    assert check.result is not None
    return check.result
