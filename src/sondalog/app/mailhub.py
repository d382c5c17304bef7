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
from ..io.mail.pop3_server import start_pop3_server
from ..io.mail.smtp_server import start_smtp_server


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
        self._smtp: asyncio.Server | None = None
        self._pop3: asyncio.Server | None = None

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
        for server in (self._smtp, self._pop3):
            if server is not None:
                server.close()
        for server in (self._smtp, self._pop3):
            if server is not None:
                await server.wait_closed()
        self._smtp = self._pop3 = None

    @staticmethod
    def _port(server: asyncio.Server | None) -> int:
        if server is None:
            raise RuntimeError("the mail hub is not running")
        port: int = server.sockets[0].getsockname()[1]
        return port

    @property
    def smtp_port(self) -> int:
        return self._port(self._smtp)

    @property
    def pop3_port(self) -> int:
        return self._port(self._pop3)

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
