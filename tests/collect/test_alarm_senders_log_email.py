"""The ``log`` and ``email`` senders (issue 21): a line per notification; an e-mail to a
real aiosmtpd, and a server that cannot be reached is a DeliveryError (retried later)."""

from __future__ import annotations

import asyncio
import logging
import socket

import pytest
from alarm_mail import smtp_server

from sondalog.collect.alarms import Message, Notify
from sondalog.collect.alarms.send_email import EmailSettings
from sondalog.collect.alarms.send_log import LogSettings
from sondalog.collect.alarms.senders import DeliveryError, find_sender, sender_for

MESSAGE = Message("3f2a9c1b12-1/raised/mail", "mail", "raised", "3f2a9c1b12-1", "x high", 0, 0)


def _mail(port: int) -> Notify[EmailSettings]:
    settings = EmailSettings(("127.0.0.1", port), "c@example.net", ("o@example.net",))
    return Notify(name="mail", kind="email", settings=settings)


def test_email_is_sent_and_an_unreachable_server_is_a_delivery_error() -> None:
    with smtp_server() as mail:
        asyncio.run(sender_for(_mail(mail.port)).send(MESSAGE))
        mail.wait(lambda: len(mail.mails) == 1)
    got = mail.mails[0]
    assert got["Subject"] == "sondalog alarm RAISED: x high"
    assert got["X-Sondalog-Key"] == MESSAGE.key and got.get_payload().strip() == "x high"
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens there now
    with pytest.raises(DeliveryError, match=f"SMTP 127.0.0.1:{port}"):
        asyncio.run(sender_for(_mail(port)).send(MESSAGE))


def test_log_sender_writes_one_line(caplog: pytest.LogCaptureFixture) -> None:
    assert find_sender("log") is not None
    sender = sender_for(Notify(name="log", kind="log", settings=LogSettings(logging.ERROR)))
    with caplog.at_level(logging.INFO, logger="sondalog.alarms"):
        asyncio.run(sender.send(MESSAGE))
    assert [(r.levelno, r.getMessage()) for r in caplog.records] == [
        (logging.ERROR, "alarm RAISED x high")
    ]
