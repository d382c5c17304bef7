"""The mail hub's SMTP server: aiosmtpd delivering into the accounts' Maildirs.

- ``RCPT TO`` an address without an account: ``550 5.1.1`` (the message is not taken).
- ``AUTH PLAIN`` / ``AUTH LOGIN`` over plain TCP with the account's address and password; a
  wrong one answers ``535``. AUTH is required only when ``auth_required`` is set.
- Each accepted message is stored once per recipient, with ``Return-Path`` and
  ``Delivered-To`` headers added in front, as a delivery agent does.
"""

from __future__ import annotations

import asyncio
import logging
import weakref
from typing import Any

from aiosmtpd.smtp import SMTP, AuthResult, Envelope, LoginPassword, Session

from .maildirs import MaildirAccounts


def _not_login_data_noise(record: logging.LogRecord) -> bool:
    # aiosmtpd 1.4 logs this on every successful AUTH, from its own code
    return "login_data is deprecated" not in record.getMessage()


logging.getLogger("mail.log").addFilter(_not_login_data_noise)


class MaildirDelivery:
    """aiosmtpd handler: local recipients only, delivery into Maildir."""

    def __init__(self, accounts: MaildirAccounts) -> None:
        self._accounts = accounts

    async def handle_RCPT(
        self,
        server: SMTP,
        session: Session,
        envelope: Envelope,
        address: str,
        rcpt_options: list[str],
    ) -> str:
        if self._accounts.refusal is not None:
            return self._accounts.refusal
        account = self._accounts.account(address)
        if account is None:
            return f"550 5.1.1 <{address}>: no such mailbox here"
        envelope.rcpt_tos.append(account)
        return "250 2.1.5 OK"

    async def handle_DATA(self, server: SMTP, session: Session, envelope: Envelope) -> str:
        content = envelope.original_content or envelope.content
        data = content if isinstance(content, bytes) else str(content).encode("utf-8")
        sender = envelope.mail_from or ""
        for account in envelope.rcpt_tos:
            head = f"Return-Path: <{sender}>\r\nDelivered-To: {account}\r\n".encode()
            await asyncio.to_thread(self._accounts.deliver, account, head + data)
        return "250 2.0.0 OK delivered"

    def authenticator(
        self, server: SMTP, session: Session, envelope: Envelope, mechanism: str, auth_data: Any
    ) -> AuthResult:
        ok = isinstance(auth_data, LoginPassword) and (
            self._accounts.check_password(
                auth_data.login.decode("utf-8", "replace"),
                auth_data.password.decode("utf-8", "replace"),
            )
            is not None
        )
        return AuthResult(success=ok, handled=False)  # handled=False: aiosmtpd answers 535


class SmtpServer:
    """A listening aiosmtpd server; :meth:`close` also ends the sessions still open."""

    def __init__(self, server: asyncio.Server, sessions: weakref.WeakSet[SMTP]) -> None:
        self.server = server
        self._sessions = sessions

    @property
    def port(self) -> int:
        port: int = self.server.sockets[0].getsockname()[1]
        return port

    async def close(self) -> None:
        self.server.close()
        for session in list(self._sessions):
            if session.transport is not None:
                session.transport.close()
        await asyncio.sleep(0)  # let the sessions see their end
        await self.server.wait_closed()


async def start_smtp_server(
    accounts: MaildirAccounts,
    host: str,
    port: int,
    *,
    hostname: str = "mail.example.net",
    auth_required: bool = False,
) -> SmtpServer:
    """Listen on ``host:port`` (0: any free port) with aiosmtpd, no Controller thread."""
    handler = MaildirDelivery(accounts)
    sessions: weakref.WeakSet[SMTP] = weakref.WeakSet()

    def factory() -> SMTP:
        session = SMTP(
            handler,
            hostname=hostname,
            authenticator=handler.authenticator,
            auth_required=auth_required,
            auth_require_tls=False,
        )
        sessions.add(session)
        return session

    loop = asyncio.get_running_loop()
    return SmtpServer(await loop.create_server(factory, host, port), sessions)
