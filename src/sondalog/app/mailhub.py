"""The mail hub: an SMTP server and a POP3 server over one set of Maildir accounts.

What ``sondalog serve`` runs for the example world's ``smtp.example.net`` (port 2525) and
``pop3.example.net`` (port 1110); see ``docs/mail.md``. Port 0 binds any free port;
:attr:`MailHub.smtp_port` and :attr:`MailHub.pop3_port` tell the ports actually bound.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from ..io.mail.maildirs import MaildirAccounts
from ..io.mail.pop3_server import Pop3Server, start_pop3_server
from ..io.mail.smtp_server import SmtpServer, start_smtp_server


@dataclass(frozen=True)
class MailHubConfig:
    """Accounts ``{address: password}``, where to listen, and the root of the Maildirs."""

    root: Path
    accounts: Mapping[str, str] = field(default_factory=dict)
    smtp_host: str = "127.0.0.1"
    smtp_port: int = 2525
    pop3_host: str = "127.0.0.1"
    pop3_port: int = 1110
    hostname: str = "mail.example.net"
    smtp_auth_required: bool = False
    pop3_timeout: float = 600.0


class MailHub:
    """Start with :meth:`start` (or ``async with``), stop with :meth:`stop`."""

    def __init__(self, config: MailHubConfig) -> None:
        self.config = config
        self.accounts = MaildirAccounts(config.root, config.accounts)
        self._smtp: SmtpServer | None = None
        self._pop3: Pop3Server | None = None

    async def start(self) -> None:
        if self._smtp is not None:
            return
        cfg = self.config
        await asyncio.to_thread(self.accounts.create_all)
        self._smtp = await start_smtp_server(
            self.accounts,
            cfg.smtp_host,
            cfg.smtp_port,
            hostname=cfg.hostname,
            auth_required=cfg.smtp_auth_required,
        )
        try:
            self._pop3 = await start_pop3_server(
                self.accounts, cfg.pop3_host, cfg.pop3_port, timeout=cfg.pop3_timeout
            )
        except BaseException:
            await self.stop()
            raise

    async def stop(self) -> None:
        """Stop listening and end the sessions still open (nothing half-delivered is kept)."""
        smtp, pop3, self._smtp, self._pop3 = self._smtp, self._pop3, None, None
        if smtp is not None:
            await smtp.close()
        if pop3 is not None:
            await pop3.close()

    def _running(self) -> tuple[SmtpServer, Pop3Server]:
        if self._smtp is None or self._pop3 is None:
            raise RuntimeError("the mail hub is not running")
        return self._smtp, self._pop3

    @property
    def smtp_port(self) -> int:
        return self._running()[0].port

    @property
    def pop3_port(self) -> int:
        return self._running()[1].port

    def maildir(self, address: str) -> Path:
        """The Maildir directory of the account ``address``."""
        account = self.accounts.account(address)
        if account is None:
            raise KeyError(address)
        return self.accounts.path(account)

    async def __aenter__(self) -> MailHub:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()
