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
from email.message import EmailMessage
from email.utils import formatdate
from typing import cast

from sondalog.config import of

from .outbox import Message
from .rules import Notify
from .senders import DeliveryError, Sender, register_sender

#: Seconds to wait for the SMTP server at each step.
TIMEOUT = 30.0


class EmailSender:
    """Sends each notification as one e-mail to ``to``."""

    def __init__(self, notify: Notify) -> None:
        t = of(notify.settings, where=f"notify.{notify.name}")
        self.name = notify.name
        # parse_notify checked them: ``smtp`` is (host, port) already, user/password None
        # when not given
        self.host, self.port = cast("tuple[str, int]", notify.settings["smtp"])
        self.sender = t.text("from")
        self.to = tuple(t.texts("to"))
        self.user = cast("str | None", notify.settings.get("user"))
        self.password = cast("str | None", notify.settings.get("password"))

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


def _factory(notify: Notify) -> Sender:
    return EmailSender(notify)


register_sender("email", _factory)
