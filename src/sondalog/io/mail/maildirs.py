"""The mail hub's accounts and their Maildir mailboxes (stdlib :mod:`mailbox`).

Layout: ``ROOT/<address>/{cur,new,tmp}``, one Maildir per account, named by the account's
full address (``ROOT/logger@example.net``). Messages are stored with LF line ends, as
Maildir readers (dovecot, mutt) expect. POP3 sessions see them oldest first (file time,
then Maildir key), each with its Maildir key as its stable UIDL.

The Maildirs are private (docs/security.md): ROOT and every Maildir directory 0700, every
message 0600, whatever the umask.
"""

from __future__ import annotations

import hmac
import mailbox
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from ...protocol.pop3_server import DropEntry, Maildrop, MaildropBusy, crlf
from ..private import PRIVATE_DIR, PRIVATE_FILE, private_dir


class MaildirAccounts:
    """Accounts ``{address: password}`` with a Maildir each under ``root``."""

    def __init__(self, root: Path, accounts: Mapping[str, str]) -> None:
        self.root = Path(root)
        self._accounts = dict(accounts)
        self._by_lower = {a.lower(): a for a in self._accounts}
        self._open: set[str] = set()
        self._sizes: dict[tuple[str, str], int] = {}  # messages never change once delivered
        #: An SMTP reply the hub answers every recipient with instead (the control API's
        #: "SMTP server refusing" fault, issue 23); None: mail is taken.
        self.refusal: str | None = None

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
        path = self.path(account)
        new = not path.is_dir()
        if new:
            private_dir(self.root)
        md = mailbox.Maildir(path, factory=None, create=True)
        if new:
            for folder in (path, path / "cur", path / "new", path / "tmp"):
                os.chmod(folder, PRIVATE_DIR)  # mailbox asks 0700, but through the umask
        return md

    def create_all(self) -> None:
        private_dir(self.root)  # 0700 even when an older version made it
        for account in self._accounts:
            self.maildir(account).close()

    def deliver(self, account: str, message: bytes) -> str:
        """Store ``message`` (any line ends) into the account's Maildir; its key."""
        data = re.sub(rb"\r\n|\r", b"\n", message)
        md = self.maildir(account)
        try:
            key = md.add(data)
            # mailbox creates it 0666 minus the umask, in tmp/ then new/ (both 0700)
            os.chmod(self.path(account) / "new" / key, PRIVATE_FILE)
            return key
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

    def size_of(self, account: str, key: str, md: mailbox.Maildir) -> int:
        """The message's POP3 size (CRLF line ends), read once and remembered."""
        size = self._sizes.get((account, key))
        if size is None:
            size = self._sizes[(account, key)] = len(crlf(md.get_bytes(key)))
        return size

    def forget(self, account: str, key: str) -> None:
        self._sizes.pop((account, key), None)


def _keys_oldest_first(path: Path) -> list[str]:
    """Maildir keys (file names up to the ``:2,`` info) by file time, then name."""
    found: list[tuple[int, str]] = []
    for sub in ("new", "cur"):
        with os.scandir(path / sub) as entries:
            for entry in entries:
                if not entry.name.startswith(".") and entry.is_file():
                    found.append((entry.stat().st_mtime_ns, entry.name.split(":")[0]))
    return [key for _time, key in sorted(found)]


class _MaildirDrop:
    """One POP3 session's locked snapshot of a Maildir."""

    def __init__(self, owner: MaildirAccounts, account: str) -> None:
        self._owner = owner
        self._account = account
        self._md = owner.maildir(account)
        self._keys = _keys_oldest_first(owner.path(account))
        self._entries = [DropEntry(k, owner.size_of(account, k, self._md)) for k in self._keys]

    def entries(self) -> Sequence[DropEntry]:
        return self._entries

    def content(self, index: int) -> bytes:
        return crlf(self._md.get_bytes(self._keys[index]))

    def commit(self, deleted: Sequence[str]) -> None:
        for key in deleted:
            self._md.discard(key)
            self._owner.forget(self._account, key)

    def release(self) -> None:
        self._md.close()
        self._owner._release(self._account)
