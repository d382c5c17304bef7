"""Webhook notifications (``[[notify]] kind = "webhook"``, issue 21): one HTTP POST of JSON
per notification.

::

    POST /hook HTTP/1.1
    Content-Type: application/json
    Idempotency-Key: 3f2a9c1b12-1709290800000/raised/hook
    X-Sondalog-Signature: sha256=<hex HMAC-SHA256 of the body with the secret>

    {"key": ..., "alarm": ..., "rule": ..., "subject": ..., "what": "raised",
     "value": 41.5, "time": "2026-12-01T20:00:00Z", "text": ..., "items": 1}

A 2xx answer delivers it; any other status, a connection that fails or no answer within
``timeout`` seconds raises :class:`~.senders.DeliveryError` and the outbox retries with
backoff. The same notification is posted again with the same ``Idempotency-Key`` (also the
body's ``key``): a receiver that remembers keys sees each notification once.

The client is the standard library's asyncio streams (HTTP/1.1, ``Connection: close``, TLS
for ``https://`` with the system's certificates): one request per connection, no new
dependency. A redirect is not followed (it is a non-2xx answer).
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import hmac
import json
import ssl
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any
from urllib.parse import urlsplit

from sondalog.config import Table

from .durations import HTTP_URL
from .outbox import Message
from .rules import Notify
from .senders import COMMON_KEYS, DeliveryError, Sender, register_sender

#: The most of an answer's status line and headers that is read.
MAX_HEAD = 16 * 1024
SIGNATURE = "X-Sondalog-Signature"


@dataclass(frozen=True, slots=True)
class WebhookSettings:
    """A ``webhook`` destination's own keys, checked."""

    url: str
    secret: str | None = None  # signs the body (``X-Sondalog-Signature``)
    timeout: float = 10.0  # seconds for the whole request


def parse(t: Table) -> WebhookSettings:
    """A ``webhook`` table's own keys (raises ``ConfigError``)."""
    t.keys(COMMON_KEYS | {"url", "secret", "timeout"})
    return WebhookSettings(
        url=t.text("url", pattern=HTTP_URL, what="an http:// or https:// URL"),
        secret=t.opt_text("secret"),
        timeout=t.number("timeout", 10.0, above=0),
    )


def payload(message: Message) -> dict[str, Any]:
    """The JSON body of ``message``."""
    when = None
    if message.time is not None:
        when = datetime.fromtimestamp(message.time, UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")
        when = when.rstrip("0").rstrip(".") + "Z"
    return {
        "key": message.key,
        "alarm": message.alarm,
        "rule": message.rule,
        "subject": message.subject,
        "what": message.what,
        "value": message.value,
        "time": when,
        "text": message.text,
        "items": message.items,
    }


def signature(secret: str, body: bytes) -> str:
    """The ``X-Sondalog-Signature`` header's value for ``body``."""
    return "sha256=" + hmac.new(secret.encode(), body, hashlib.sha256).hexdigest()


class Webhook:
    """POSTs notifications to ``url``."""

    def __init__(self, url: str, secret: str | None, timeout: float) -> None:
        parts = urlsplit(url)
        self.url = url
        self.tls = parts.scheme == "https"
        self.host = parts.hostname or ""
        self.port = parts.port or (443 if self.tls else 80)
        self.target = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
        self.netloc = parts.netloc.rpartition("@")[2]
        self.secret = secret
        self.timeout = timeout

    def request(self, message: Message) -> bytes:
        """The whole HTTP request for ``message``."""
        body = json.dumps(payload(message), ensure_ascii=False).encode()
        head = [
            f"POST {self.target} HTTP/1.1",
            f"Host: {self.netloc}",
            "User-Agent: sondalog",
            "Content-Type: application/json",
            f"Content-Length: {len(body)}",
            f"Idempotency-Key: {message.key}",
            "Connection: close",
        ]
        if self.secret is not None:
            head.append(f"{SIGNATURE}: {signature(self.secret, body)}")
        return ("\r\n".join(head) + "\r\n\r\n").encode() + body

    async def send(self, message: Message) -> None:
        try:
            status = await asyncio.wait_for(self._post(self.request(message)), self.timeout)
        except TimeoutError:
            raise DeliveryError(f"{self.url}: no answer in {self.timeout:g} s") from None
        except (OSError, ssl.SSLError, ValueError) as exc:
            raise DeliveryError(f"{self.url}: {exc}") from None
        if not 200 <= status < 300:
            raise DeliveryError(f"{self.url}: HTTP {status}")

    async def _post(self, request: bytes) -> int:
        context = ssl.create_default_context() if self.tls else None
        reader, writer = await asyncio.open_connection(
            self.host, self.port, ssl=context, limit=MAX_HEAD
        )
        try:
            writer.write(request)
            await writer.drain()
            try:
                line = await reader.readuntil(b"\r\n")
            except asyncio.IncompleteReadError:
                raise ValueError("the connection closed without an answer") from None
            except asyncio.LimitOverrunError:
                raise ValueError("the answer's status line is too long") from None
            parts = line.decode("latin-1").split(" ", 2)
            if len(parts) < 2 or not parts[0].startswith("HTTP/") or not parts[1].isdigit():
                raise ValueError(f"not an HTTP answer: {line[:80]!r}")
            return int(parts[1])
        finally:
            writer.close()
            with contextlib.suppress(OSError, ssl.SSLError, TimeoutError):
                await asyncio.wait_for(writer.wait_closed(), 1.0)

    async def close(self) -> None:
        return None


def create(notify: Notify[WebhookSettings]) -> Sender:
    s = notify.settings
    return Webhook(s.url, s.secret, s.timeout)


register_sender("webhook", create, parse)
