"""The logger's SMTP client (RFC 5321), sans-I/O (§6.11.6.3, §6.13, §6.14; gsm.md §4).

One client object sends one message over one connection:

1. wait for the ``220`` greeting;
2. ``EHLO name``; a ``500``/``502`` (or any 5xx) answer falls back to ``HELO name``;
3. with credentials (``user:password@`` in the server spec): ``AUTH PLAIN`` when the server
   offers PLAIN or offers no mechanism list at all, else ``AUTH LOGIN`` when offered;
4. ``MAIL FROM:<from>``, then ``RCPT TO:<to>`` for each recipient: a refused recipient
   refuses the whole message (the logger needs to know that every address got it);
5. ``DATA``, the message with line ends made CRLF and lines starting with ``.`` doubled, the
   ``.`` line; ``250`` means sent;
6. ``QUIT`` (sent also after a refusal), then the caller closes the connection.

The result (:class:`SmtpResult`, also the last event) is ``sent``, ``refused`` (with the
server's reply), ``timeout`` (no complete reply within ``timeout`` seconds of the last
command) or ``broken`` (the server closed the connection or spoke no SMTP). Every server
reply is also an event (:class:`SmtpReply`), for tracing.
"""

from __future__ import annotations

import base64
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from .line_client import LineClient
from .mail_text import dot_stuff as dot_stuff

SmtpOutcome = Literal["sent", "refused", "timeout", "broken"]


@dataclass(frozen=True)
class SmtpReply:
    """One complete server reply: its code and its text lines (without the codes)."""

    code: int
    lines: tuple[str, ...]

    @property
    def text(self) -> str:
        return f"{self.code} " + " / ".join(self.lines)


@dataclass(frozen=True)
class SmtpResult:
    """What became of the message, at which step, and the server reply that decided it."""

    outcome: SmtpOutcome
    stage: str
    reply: SmtpReply | None = None
    detail: str = ""

    @property
    def sent(self) -> bool:
        return self.outcome == "sent"

    def __str__(self) -> str:
        why = self.reply.text if self.reply is not None else self.detail
        return f"{self.outcome} at {self.stage}: {why}" if why else f"{self.outcome}"


def _b64(data: bytes) -> bytes:
    return base64.b64encode(data)


def _envelope_address(addr: str) -> str:
    if any(c in addr for c in "\r\n<>") or any(c.isspace() for c in addr):
        raise ValueError(f"bad envelope address {addr!r}")
    return addr


class SmtpClient(LineClient[SmtpResult]):
    """Sends ``message`` from ``sender`` to ``recipients`` through one SMTP conversation."""

    def __init__(
        self,
        sender: str,
        recipients: list[str] | tuple[str, ...],
        message: bytes,
        *,
        helo_name: str = "ala1",
        user: str | None = None,
        password: str | None = None,
        timeout: float = 60.0,
    ) -> None:
        super().__init__(timeout)
        if not recipients:
            raise ValueError("no recipients")
        self._sender = _envelope_address(sender) if sender else ""
        self._recipients = [_envelope_address(r) for r in recipients]
        self._payload = dot_stuff(message)
        self._helo = helo_name
        self._user = user
        self._password = password or ""
        self._stage = "greeting"
        self._rcpt_index = 0
        self._reply_lines: list[str] = []
        self._mechanisms: list[str] | None = None  # None: EHLO listed no AUTH

    # -- replies -----------------------------------------------------------------------
    def _line(self, line: bytes, now: float) -> None:
        text = line.decode("utf-8", "replace")
        if len(text) < 3 or not text[:3].isdigit() or (len(text) > 3 and text[3] not in " -"):
            self._broken(f"not an SMTP reply: {text[:80]!r}")
            return
        self._reply_lines.append(text[4:])
        if len(text) > 3 and text[3] == "-":
            return
        reply = SmtpReply(int(text[:3]), tuple(self._reply_lines))
        self._reply_lines = []
        self._emit(reply)
        self._reply(reply, now)

    def _reply(self, reply: SmtpReply, now: float) -> None:
        code, stage = reply.code, self._stage
        if stage == "quit":
            self._close()
        elif stage == "greeting":
            self._ok(reply, now, code == 220, self._ehlo)
        elif stage == "ehlo":
            if code == 250:
                self._mechanisms = self._auth_mechanisms(reply)
                self._after_hello(now)
            elif 500 <= code < 600:
                self._command("helo", f"HELO {self._helo}", now)
            else:
                self._refuse(reply, now)
        elif stage == "helo":
            self._ok(reply, now, code == 250, self._after_hello)
        elif stage == "auth plain" and code == 334:
            self._command("auth plain response", self._plain_token(), now)
        elif stage in ("auth plain", "auth plain response", "auth login password"):
            self._ok(reply, now, code == 235, self._mail)
        elif stage == "auth login":
            user = (self._user or "").encode()
            self._ok(reply, now, code == 334, lambda t: self._secret("auth login user", user, t))
        elif stage == "auth login user":
            pw = self._password.encode()
            self._ok(reply, now, code == 334, lambda t: self._secret("auth login password", pw, t))
        elif stage == "mail":
            self._ok(reply, now, code == 250, self._rcpt)
        elif stage == "rcpt":
            self._ok(reply, now, code in (250, 251), self._rcpt)
        elif stage == "data":
            self._ok(reply, now, code == 354, self._body)
        elif stage == "body":
            if code == 250:
                self._finish(SmtpResult("sent", "data", reply))
                self._command("quit", "QUIT", now)
            else:
                self._refuse(reply, now)

    def _ok(self, reply: SmtpReply, now: float, good: bool, then: Callable[[float], None]) -> None:
        if good:
            then(now)
        else:
            self._refuse(reply, now)

    # -- commands ----------------------------------------------------------------------
    def _command(self, stage: str, line: str, now: float) -> None:
        self._stage = stage
        self._send(line.encode("utf-8") + b"\r\n", now)

    def _secret(self, stage: str, value: bytes, now: float) -> None:
        self._command(stage, _b64(value).decode(), now)

    def _ehlo(self, now: float) -> None:
        self._command("ehlo", f"EHLO {self._helo}", now)

    @staticmethod
    def _auth_mechanisms(reply: SmtpReply) -> list[str] | None:
        for line in reply.lines[1:]:
            words = line.upper().replace("=", " ").split()
            if words and words[0] == "AUTH":
                return words[1:]
        return None

    def _plain_token(self) -> str:
        user = (self._user or "").encode()
        return _b64(b"\0" + user + b"\0" + self._password.encode()).decode()

    def _after_hello(self, now: float) -> None:
        if self._user is None:
            self._mail(now)
        elif self._mechanisms is None or "PLAIN" in self._mechanisms:
            self._command("auth plain", f"AUTH PLAIN {self._plain_token()}", now)
        elif "LOGIN" in self._mechanisms:
            self._command("auth login", "AUTH LOGIN", now)
        else:
            self._command("auth plain", f"AUTH PLAIN {self._plain_token()}", now)

    def _mail(self, now: float) -> None:
        self._command("mail", f"MAIL FROM:<{self._sender}>", now)

    def _rcpt(self, now: float) -> None:
        if self._rcpt_index < len(self._recipients):
            rcpt = self._recipients[self._rcpt_index]
            self._rcpt_index += 1
            self._command("rcpt", f"RCPT TO:<{rcpt}>", now)
        else:
            self._command("data", "DATA", now)

    def _body(self, now: float) -> None:
        self._stage = "body"
        self._send(self._payload, now)

    # -- endings -----------------------------------------------------------------------
    def _refuse(self, reply: SmtpReply, now: float) -> None:
        self._finish(SmtpResult("refused", self._stage, reply))
        self._command("quit", "QUIT", now)

    def _timed_out(self, now: float) -> None:
        self._finish(SmtpResult("timeout", self._stage, detail="no reply in time"))
        self._close()

    def _closed_by_peer(self) -> None:
        self._finish(SmtpResult("broken", self._stage, detail="connection closed by server"))
        self._close()

    def _broken(self, why: str) -> None:
        self._finish(SmtpResult("broken", self._stage, detail=why))
        self._close()
