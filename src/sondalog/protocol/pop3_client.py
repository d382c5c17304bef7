"""The logger's check of its command mailbox (RFC 1939), sans-I/O (§3.4.6.2, §6.11.6.4).

After each e-mail it sends, the logger looks into its mailbox once (gsm.md §4):

``USER`` / ``PASS`` (a ``-ERR`` to either: ``auth_failed``; ``failed`` when its response code
says the mailbox is busy, ``[IN-USE]`` or ``[SYS/TEMP]``) -> ``STAT`` (no message: ``none``)
-> ``LIST 1``: the oldest message is larger than ``pop3 size`` bytes -> ``DELE 1`` unread
(``too_big``); otherwise ``RETR 1`` which must end within ``pop3 time`` seconds -> ``DELE 1``
-> ``QUIT`` -> ``mail`` with the message's bytes (dot-unstuffed, CRLF line ends).

A download that overruns ``pop3 time`` is abandoned: the core asks the caller to drop the
connection without ``QUIT``, so the server never enters its UPDATE state and the message
stays for the next check (``timeout``). A message counts as taken only once the server
answered ``+OK`` to ``QUIT`` (RFC 1939 deletes only then): a connection lost before that
leaves the message in the mailbox and yields no command, so a command is never run twice.

Other ends: ``timeout`` (no answer within ``timeout`` seconds), ``failed`` (``-ERR`` to
``STAT``, ``LIST``, ``RETR``, ``DELE`` or ``QUIT``), ``broken`` (connection closed, not POP3).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from .line_client import LineClient

Pop3Outcome = Literal["mail", "none", "auth_failed", "too_big", "timeout", "failed", "broken"]


@dataclass(frozen=True)
class Pop3Response:
    """One status line from the server (``+OK`` or ``-ERR``), for tracing."""

    ok: bool
    text: str


@dataclass(frozen=True)
class Pop3Result:
    """The end of one mailbox check."""

    outcome: Pop3Outcome
    stage: str
    message: bytes | None = None
    size: int | None = None
    detail: str = ""

    def __str__(self) -> str:
        size = f" ({self.size} bytes)" if self.size is not None else ""
        return f"{self.outcome} at {self.stage}{size}: {self.detail}".rstrip(": ")


class Pop3Check(LineClient[Pop3Result]):
    """One check of the command mailbox ``user``/``password`` (§6.11.6.4)."""

    def __init__(
        self,
        user: str,
        password: str,
        *,
        max_size: int,
        time_limit: float,
        timeout: float = 60.0,
    ) -> None:
        super().__init__(timeout)
        for name, value in (("user", user), ("password", password)):
            if any(c in value for c in "\r\n"):
                raise ValueError(f"{name} must not hold a line end")
        if max_size < 0 or time_limit < 0:
            raise ValueError("max_size and time_limit must not be negative")
        self._user = user
        self._password = password
        self._max_size = max_size
        self._time_limit = time_limit
        self._stage = "greeting"
        self._size: int | None = None
        self._pending: Pop3Result | None = None  # decided, waiting for QUIT's +OK
        self._body: bytearray | None = None  # while RETR's lines arrive

    # -- input -------------------------------------------------------------------------
    def _line(self, line: bytes, now: float) -> None:
        if self._body is not None:
            self._data_line(line, now)
            return
        text = line.decode("utf-8", "replace")
        if text.startswith("+OK"):
            ok = True
        elif text.startswith("-ERR"):
            ok = False
        else:
            self._broken(f"not a POP3 status line: {text[:80]!r}")
            return
        rest = text[3 if ok else 4 :].strip()
        self._emit(Pop3Response(ok, rest))
        self._response(ok, rest, now)

    def _data_line(self, line: bytes, now: float) -> None:
        assert self._body is not None
        if line == b".":
            message = bytes(self._body)
            self._body = None
            self._pending = Pop3Result("mail", "retr", message, self._size)
            self._stage = "dele"
            self._send(b"DELE 1\r\n", now)
            return
        self._body += (line[1:] if line.startswith(b".") else line) + b"\r\n"
        if len(self._body) > self._body_limit():
            self._broken("the server sent far more than the size it listed")

    def _response(self, ok: bool, text: str, now: float) -> None:
        stage = self._stage
        if stage == "quit":
            if ok and self._pending is not None:
                self._finish(self._pending)
            elif self._pending is not None:
                self._finish(Pop3Result("failed", "quit", None, self._size, f"-ERR {text}"))
            self._close()
        elif stage == "greeting":
            self._step(ok, text, now, "user", f"USER {self._user}")
        elif stage in ("user", "pass"):
            if not ok:
                busy = text.startswith(("[IN-USE]", "[SYS/TEMP]"))  # RFC 2449 codes
                outcome: Pop3Outcome = "failed" if busy else "auth_failed"
                self._finish(Pop3Result(outcome, stage, detail=f"-ERR {text}"))
                self._quit(now)
            elif stage == "user":
                self._step(ok, text, now, "pass", f"PASS {self._password}")
            else:
                self._step(ok, text, now, "stat", "STAT")
        elif stage == "stat":
            count = self._number(text, 0)
            if count is None or not ok:
                self._fail(ok, text, now)
            elif count == 0:
                self._pending = Pop3Result("none", "stat")
                self._quit(now)
            else:
                self._step(ok, text, now, "list", "LIST 1")
        elif stage == "list":
            size = self._number(text, 1)
            if size is None or not ok:
                self._fail(ok, text, now)
            else:
                self._size = size
                if size > self._max_size:
                    self._step(ok, text, now, "dele big", "DELE 1")
                else:
                    self._stage = "retr"
                    self._send(b"RETR 1\r\n", now, self._time_limit)
        elif stage == "retr":
            if ok:
                self._body = bytearray()  # the download's deadline stays as it was
                self.max_line = self._body_limit()  # a mail's lines may be long
            else:
                self._fail(ok, text, now)
        elif stage == "dele big":
            if ok:
                self._pending = Pop3Result("too_big", "list", None, self._size, "deleted unread")
                self._quit(now)
            else:
                self._fail(ok, text, now)
        elif stage == "dele":
            if ok:
                self._quit(now)
            else:
                self._pending = None
                self._fail(ok, text, now)

    def _body_limit(self) -> int:
        return 2 * max(self._max_size, self._size or 0) + 65536

    @staticmethod
    def _number(text: str, index: int) -> int | None:
        words = text.split()
        if len(words) > index and words[index].isdigit():
            return int(words[index])
        return None

    # -- output ------------------------------------------------------------------------
    def _step(self, ok: bool, text: str, now: float, stage: str, command: str) -> None:
        if not ok:
            self._fail(ok, text, now)
            return
        self._stage = stage
        self._send(command.encode("utf-8") + b"\r\n", now)

    def _quit(self, now: float) -> None:
        self._stage = "quit"
        self._send(b"QUIT\r\n", now)

    # -- endings -----------------------------------------------------------------------
    def _fail(self, ok: bool, text: str, now: float) -> None:
        why = f"-ERR {text}" if not ok else f"unexpected answer {text!r}"
        self._finish(Pop3Result("failed", self._stage, None, self._size, why))
        self._quit(now)

    def _timed_out(self, now: float) -> None:
        if self._stage == "retr":
            why = "download over pop3 time: abandoned, left in the mailbox"
        else:
            why = "no answer in time"
        self._finish(Pop3Result("timeout", self._stage, None, self._size, why))
        self._close()

    def _closed_by_peer(self) -> None:
        self._finish(Pop3Result("broken", self._stage, None, self._size, "connection closed"))
        self._close()

    def _broken(self, why: str) -> None:
        self._finish(Pop3Result("broken", self._stage, None, self._size, why))
        self._close()
