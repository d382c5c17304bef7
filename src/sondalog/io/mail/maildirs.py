"""The mail hub's accounts and their Maildir mailboxes (stdlib :mod:`mailbox`).

Layout: ``ROOT/<address>/{cur,new,tmp}``, one Maildir per account, named by the account's
full address (``ROOT/logger@example.net``). Messages are stored with LF line ends, as
Maildir readers (dovecot, mutt) expect. POP3 sessions see them oldest first (file time,
then Maildir key), each with its Maildir key as its stable UIDL.
"""

from __future__ import annotations

import hmac
import mailbox
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from ...protocol.pop3_server import DropEntry, Maildrop, MaildropBusy, crlf


class MaildirAccounts:
    """Accounts ``{address: password}`` with a Maildir each under ``root``."""

    def __init__(self, root: Path, accounts: Mapping[str, str]) -> None:
        self.root = Path(root)
        self._accounts = dict(accounts)
        self._by_lower = {a.lower(): a for a in self._accounts}
        self._open: set[str] = set()

    def account(self, address: str) -> str | None:
        """The account of ``address`` (compared without regard to case), if any."""
        return self._by_lower.get(address.strip().lower())

    def check_password(self, login: str, password: str) -> str | None:
        account = self.account(login)
        if account is None:
            return None
        ok = hmac.compare_digest(self._accounts[account].encode(), password.encode())
        return account if ok else None

    def path(self, account: str) -> Path:
        return self.root / account

    def maildir(self, account: str) -> mailbox.Maildir:
        self.root.mkdir(parents=True, exist_ok=True)
        return mailbox.Maildir(self.path(account), factory=None, create=True)

    def create_all(self) -> None:
        for account in self._accounts:
            self.maildir(account).close()

    def deliver(self, account: str, message: bytes) -> str:
        """Store ``message`` (any line ends) into the account's Maildir; its key."""
        data = re.sub(rb"\r\n|\r", b"\n", message)
        md = self.maildir(account)
        try:
            return md.add(data)
        finally:
            md.close()

    # -- the POP3 store ----------------------------------------------------------------
    def open(self, user: str, password: str) -> Maildrop | None:
        account = self.check_password(user, password)
        if account is None:
            return None
        if account in self._open:
            raise MaildropBusy(account)
        drop = _MaildirDrop(self, account)
        self._open.add(account)
        return drop

    def _release(self, account: str) -> None:
        self._open.discard(account)


class _MaildirDrop:
    """One POP3 session's locked snapshot of a Maildir."""

    def __init__(self, owner: MaildirAccounts, account: str) -> None:
        self._owner = owner
        self._account = account
        self._md = owner.maildir(account)
        dated = []
        for key in self._md.iterkeys():
            msg = self._md.get_message(key)
            assert isinstance(msg, mailbox.MaildirMessage)
            dated.append((msg.get_date(), key))
        self._keys = [key for _date, key in sorted(dated)]
        self._entries = [DropEntry(k, len(crlf(self._md.get_bytes(k)))) for k in self._keys]

    def entries(self) -> Sequence[DropEntry]:
        return self._entries

    def content(self, index: int) -> bytes:
        return crlf(self._md.get_bytes(self._keys[index]))

    def commit(self, deleted: Sequence[str]) -> None:
        for key in deleted:
            self._md.discard(key)

    def release(self) -> None:
        self._md.close()
        self._owner._release(self._account)
