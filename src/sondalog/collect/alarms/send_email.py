"""``kind = "email"`` destinations: a notification is one e-mail over SMTP (issue 21).

::

    [[notify]]
    name = "ops-mail"
    kind = "email"
    smtp = "mail.example.net:587"    # HOST:PORT
    from = "collector@example.net"
    to = ["ops@example.net"]
    user = "collector"               # optional: STARTTLS (when offered) and AUTH
    password = "..."

Subject: the message's title (``sondalog alarm RAISED: ...``); body: its text. The
outbox row's key is sent as the ``Message-ID``'s local part, so a receiver can tell a
repeated delivery (kill -9 between sending and marking it sent) from a new message.
``smtplib`` runs in a worker thread; a server that refuses the message, or cannot be
reached, is a :class:`~.senders.DeliveryError` (the row waits and is retried).
"""

from __future__ import annotations

import asyncio
import smtplib
import ssl
from dataclasses import dataclass
from email.message import EmailMessage
from email.utils import formatdate

from sondalog.config import Table

from .durations import many_matching
from .outbox import Message
from .rules import Notify
from .senders import COMMON_KEYS, DeliveryError, Sender, register_sender

#: Seconds to wait for the SMTP server at each step.
TIMEOUT = 30.0
_EMAIL = r"[^@\s]+@[^@\s]+"


@dataclass(frozen=True, slots=True)
class EmailSettings:
    """An ``email`` destination's own keys, checked."""

    smtp: tuple[str, int]  # host, port
    sender: str  # ``from``
    to: tuple[str, ...]
    user: str | None = None  # with ``password``: STARTTLS (when offered) and AUTH
    password: str | None = None


def parse(t: Table) -> EmailSettings:
    """An ``email`` table's own keys (raises ``ConfigError``)."""
    t.keys(COMMON_KEYS | {"smtp", "from", "to", "user", "password"})
    return EmailSettings(
        smtp=t.address("smtp"),
        sender=t.text("from", pattern=_EMAIL, what="an e-mail address"),
        to=many_matching(t, "to", _EMAIL, "e-mail addresses"),
        user=t.opt_text("user"),
        password=t.opt_text("password"),
    )


class EmailSender:
    """Sends each notification as one e-mail to ``to``."""

    def __init__(self, settings: EmailSettings) -> None:
        self.host, self.port = settings.smtp
        self.sender = settings.sender
        self.to = settings.to
        self.user = settings.user
        self.password = settings.password

    def mail(self, message: Message) -> EmailMessage:
        mail = EmailMessage()
        mail["From"] = self.sender
        mail["To"] = ", ".join(self.to)
        mail["Subject"] = message.title.replace("\n", " ")[:200]
        mail["Date"] = formatdate(localtime=True)
        mail["Message-ID"] = f"<{message.key.replace('/', '.')}@sondalog>"
        mail["X-Sondalog-Key"] = message.key
        mail.set_content(message.text + "\n")
        return mail

    def _send(self, mail: EmailMessage) -> None:
        try:
            with smtplib.SMTP(self.host, self.port, timeout=TIMEOUT) as smtp:
                smtp.ehlo()
                if self.user is not None:
                    if smtp.has_extn("starttls"):
                        smtp.starttls(context=ssl.create_default_context())
                        smtp.ehlo()
                    smtp.login(self.user, self.password or "")
                refused = smtp.send_message(mail, self.sender, list(self.to))
        except (smtplib.SMTPException, OSError) as exc:
            text = str(exc) or type(exc).__name__
            raise DeliveryError(f"SMTP {self.host}:{self.port}: {text}") from exc
        if refused:
            raise DeliveryError(f"SMTP {self.host}:{self.port} refused {', '.join(refused)}")

    async def send(self, message: Message) -> None:
        await asyncio.to_thread(self._send, self.mail(message))

    async def close(self) -> None:
        return None


def _factory(notify: Notify[EmailSettings]) -> Sender:
    return EmailSender(notify.settings)


register_sender("email", _factory, parse)
