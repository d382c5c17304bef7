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

from ..config import Table
from ..io.mail.maildirs import MaildirAccounts
from ..io.mail.pop3_server import Pop3Server, start_pop3_server
from ..io.mail.smtp_server import SmtpServer, start_smtp_server
from ..protocol.mail_address import MailAddressError, check_address


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


_MAIL = {"smtp", "pop3", "hostname", "smtp_auth_required", "accounts"}


def parse_mail(table: Table, root: Path) -> MailHubConfig:
    """A site file's ``[mail]`` table: ``smtp``/``pop3`` as ``"host:port"``, ``hostname``,
    ``smtp_auth_required`` and ``[mail.accounts]`` ``"address" = "password"``; the Maildirs
    under ``root``. Raises :class:`~sondalog.config.ConfigError` naming the field."""
    table.keys(_MAIL)
    accounts_table = table.table("accounts")
    accounts = {}
    for address in accounts_table:
        try:
            check_address(address)
        except MailAddressError as exc:
            raise accounts_table.fail(address, str(exc)) from None
        accounts[address] = accounts_table.text(address, what="a password in quotes", empty=True)
    smtp = table.address("smtp", "127.0.0.1:2525")
    pop3 = table.address("pop3", "127.0.0.1:1110")
    hostname = table.text("hostname", "mail.example.net")
    required = table.flag("smtp_auth_required", False)
    return MailHubConfig(root, accounts, smtp[0], smtp[1], pop3[0], pop3[1], hostname, required)


def example_config(root: Path) -> MailHubConfig:
    """The example world's hub (issue 12): SMTP 127.0.0.1:2525, POP3 127.0.0.1:1110, accounts
    ``logger@example.net`` and ``user@example.net`` with password ``secret``."""
    accounts = {"logger@example.net": "secret", "user@example.net": "secret"}
    return MailHubConfig(root, accounts)


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
