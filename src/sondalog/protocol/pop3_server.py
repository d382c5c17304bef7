"""A POP3 server session (RFC 1939, RFC 2449 CAPA), sans-I/O, over an abstract maildrop.

Serves the mail hub's mailboxes (issue 12, item 6). States of RFC 1939:

- AUTHORIZATION: ``CAPA``, ``USER``, ``PASS``, ``QUIT``. A wrong user or password answers
  ``-ERR [AUTH] ...`` and the session stays in AUTHORIZATION; a mailbox held by another
  session answers ``-ERR [IN-USE] ...``.
- TRANSACTION: ``STAT``, ``LIST [n]``, ``UIDL [n]``, ``RETR n``, ``TOP n m``, ``DELE n``,
  ``RSET``, ``NOOP``, ``CAPA``, ``QUIT``. The message list is the snapshot taken at login.
- UPDATE (only after ``QUIT`` in TRANSACTION): messages marked deleted are removed from the
  store. A dropped connection or the autologout timer (``timeout``, RFC 1939's 10 minutes)
  removes nothing.

The store (:class:`Pop3Store`) is the only way out of the core; sizes are octets of the
message with CRLF line ends, as RETR sends it before byte-stuffing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from .mail_text import byte_stuff, crlf_lines
from .mail_text import crlf as crlf

MAX_COMMAND = 1024  # RFC 2449: 255 octets; generous to clients, still bounded


@dataclass(frozen=True)
class DropEntry:
    """One message of a maildrop snapshot: its unique id (RFC 1939 UIDL) and its size."""

    uid: str
    size: int


class Maildrop(Protocol):
    """An open, locked mailbox: a snapshot of its messages, oldest first."""

    def entries(self) -> Sequence[DropEntry]: ...

    def content(self, index: int) -> bytes:
        """The message at ``index`` (0-based) with CRLF line ends."""
        ...

    def commit(self, deleted: Sequence[str]) -> None:
        """UPDATE state: remove the messages with these uids (may raise OSError)."""
        ...

    def release(self) -> None:
        """The session ended: unlock the mailbox."""
        ...


class MaildropBusy(Exception):
    """The mailbox is already open in another session."""


class Pop3Store(Protocol):
    def open(self, user: str, password: str) -> Maildrop | None:
        """The user's maildrop, ``None`` for a bad user or password; may raise MaildropBusy."""
        ...


CAPABILITIES = ("USER", "UIDL", "TOP", "RESP-CODES", "PIPELINING", "IMPLEMENTATION sondalog")


class Pop3Session:
    """One client connection."""

    def __init__(self, store: Pop3Store, *, timeout: float = 600.0) -> None:
        self._store = store
        self._timeout = timeout
        self._in = bytearray()
        self._out = bytearray()
        self._user: str | None = None
        self._drop: Maildrop | None = None
        self._entries: Sequence[DropEntry] = ()
        self._deleted: set[int] = set()
        self._deadline: float | None = None
        self.wants_close = False

    # -- the caller's side -------------------------------------------------------------
    def start(self, now: float) -> None:
        self._reply(True, "sondalog POP3 server ready", now)

    @property
    def deadline(self) -> float | None:
        return None if self.wants_close else self._deadline

    def data_to_send(self) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        return out

    def receive_data(self, data: bytes, now: float) -> None:
        """Bytes from the client; ``b""`` when it closed the connection (no UPDATE)."""
        if self.wants_close:
            return
        if not data:
            self._end()
            return
        self._in += data
        while not self.wants_close:
            end = self._in.find(b"\n")
            if end < 0:
                break
            line = bytes(self._in[:end]).rstrip(b"\r")
            del self._in[: end + 1]
            if len(line) > MAX_COMMAND:
                self._reply(False, "line too long", now)
            else:
                self._command(line.decode("utf-8", "replace"), now)
        if len(self._in) > MAX_COMMAND:
            self._in.clear()
            self._reply(False, "line too long", now)

    def handle_timeout(self, now: float) -> None:
        """Autologout: close without UPDATE."""
        if self._deadline is not None and now >= self._deadline and not self.wants_close:
            self._end()

    def connection_lost(self) -> None:
        if not self.wants_close:
            self._end()

    # -- commands ----------------------------------------------------------------------
    def _command(self, line: str, now: float) -> None:
        words = line.split(" ")
        keyword, args = words[0].upper(), [w for w in words[1:] if w]
        if keyword == "CAPA":
            self._multi("capability list follows", [c.encode() for c in CAPABILITIES], now)
        elif keyword == "QUIT":
            self._quit(now)
        elif self._drop is None:
            self._authorization(keyword, line, args, now)
        else:
            self._transaction(keyword, args, now)

    def _authorization(self, keyword: str, line: str, args: list[str], now: float) -> None:
        if keyword == "USER" and len(args) == 1:
            self._user = args[0]
            self._reply(True, "send PASS", now)
        elif keyword == "PASS" and self._user is not None and len(line) > 5:
            user, self._user = self._user, None
            try:
                drop = self._store.open(user, line[5:])  # the password may hold spaces
            except MaildropBusy:
                self._reply(False, "[IN-USE] mailbox is open in another session", now)
                return
            if drop is None:
                self._reply(False, "[AUTH] invalid user name or password", now)
                return
            self._drop, self._entries = drop, list(drop.entries())
            count, size = self._stat()
            self._reply(True, f"logged in, {count} messages ({size} octets)", now)
        elif keyword in ("USER", "PASS"):
            self._user = None
            self._reply(False, f"{keyword} needs USER name then PASS password", now)
        else:
            self._reply(False, f"command {keyword[:20]!r} not valid before login", now)

    def _transaction(self, keyword: str, args: list[str], now: float) -> None:
        drop = self._drop
        assert drop is not None
        if keyword == "NOOP" and not args:
            self._reply(True, "", now)
        elif keyword == "STAT" and not args:
            count, size = self._stat()
            self._reply(True, f"{count} {size}", now)
        elif keyword in ("LIST", "UIDL") and len(args) <= 1:
            self._listing(keyword, args, now)
        elif keyword == "RETR" and len(args) == 1:
            index = self._message(args[0], now)
            if index is not None:
                lines = crlf_lines(drop.content(index))
                self._multi(f"{sum(len(ln) + 2 for ln in lines)} octets", lines, now)
        elif keyword == "TOP" and len(args) == 2:
            index = self._message(args[0], now)
            if index is not None:
                if not args[1].isdigit():
                    self._reply(False, "TOP needs a number of lines", now)
                    return
                self._multi("top of message follows", self._top(index, int(args[1])), now)
        elif keyword == "DELE" and len(args) == 1:
            index = self._message(args[0], now)
            if index is not None:
                self._deleted.add(index)
                self._reply(True, f"message {index + 1} deleted", now)
        elif keyword == "RSET" and not args:
            self._deleted.clear()
            count, size = self._stat()
            self._reply(True, f"maildrop has {count} messages ({size} octets)", now)
        else:
            self._reply(False, f"unknown command or bad arguments: {keyword[:20]!r}", now)

    def _listing(self, keyword: str, args: list[str], now: float) -> None:
        def item(i: int) -> str:
            e = self._entries[i]
            return f"{i + 1} {e.size if keyword == 'LIST' else e.uid}"

        if args:
            index = self._message(args[0], now)
            if index is not None:
                self._reply(True, item(index), now)
            return
        live = [i for i in range(len(self._entries)) if i not in self._deleted]
        count, size = self._stat()
        head = f"{count} messages ({size} octets)" if keyword == "LIST" else ""
        self._multi(head, [item(i).encode() for i in live], now)

    def _top(self, index: int, n: int) -> list[bytes]:
        assert self._drop is not None
        lines = crlf_lines(self._drop.content(index))
        try:
            blank = lines.index(b"")
        except ValueError:
            return lines
        return lines[: blank + 1 + n]

    def _message(self, arg: str, now: float) -> int | None:
        if not arg.isdigit() or not 1 <= int(arg) <= len(self._entries):
            self._reply(False, f"no such message: {arg[:20]!r}", now)
            return None
        index = int(arg) - 1
        if index in self._deleted:
            self._reply(False, f"message {index + 1} already deleted", now)
            return None
        return index

    def _stat(self) -> tuple[int, int]:
        live = [e for i, e in enumerate(self._entries) if i not in self._deleted]
        return len(live), sum(e.size for e in live)

    def _quit(self, now: float) -> None:
        if self._drop is None:
            self._reply(True, "bye", now)
        else:
            uids = [self._entries[i].uid for i in sorted(self._deleted)]
            try:
                self._drop.commit(uids)
            except OSError:
                self._reply(False, "[SYS/TEMP] some deleted messages not removed", now)
            else:
                self._reply(True, f"bye, {len(uids)} messages deleted", now)
        self._end()

    # -- output ------------------------------------------------------------------------
    def _reply(self, ok: bool, text: str, now: float) -> None:
        status = b"+OK" if ok else b"-ERR"
        self._out += status + (b" " + text.encode() if text else b"") + b"\r\n"
        self._deadline = now + self._timeout

    def _multi(self, text: str, lines: Sequence[bytes], now: float) -> None:
        self._reply(True, text, now)
        self._out += byte_stuff(lines)

    def _end(self) -> None:
        self.wants_close = True
        self._deadline = None
        if self._drop is not None:
            drop, self._drop = self._drop, None
            drop.release()
