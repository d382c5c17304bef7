"""Webhook notifications (issue 21) against a real HTTP receiver on 127.0.0.1: the JSON
body, the Idempotency-Key, the HMAC signature checked by the receiver; non-2xx, refused
connections and silence are delivery errors; and the outbox's retries with backoff on a
stepped clock deliver a notification exactly once to a receiver that fails twice."""

from __future__ import annotations

import asyncio
import hashlib
import hmac
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field, replace
from typing import Any

import pytest
from alarm_helpers import T0, plan_of, sample

from sondalog.collect.alarms import Alarms, MemoryOutbox, Message, Notify, Policy
from sondalog.collect.alarms.send_webhook import WebhookSettings
from sondalog.collect.alarms.senders import DeliveryError, sender_for

SECRET = "s3cret"


@dataclass
class Receiver:
    """An HTTP receiver: answers each request with the next status of ``statuses`` (then
    200), or never (``silent``); checks the signature with ``SECRET``."""

    statuses: list[int] = field(default_factory=list)
    silent: bool = False
    requests: list[tuple[str, dict[str, str], bytes]] = field(default_factory=list)
    port: int = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/hook?x=1"

    def signed(self, i: int) -> bool:
        _, headers, body = self.requests[i]
        good = "sha256=" + hmac.new(SECRET.encode(), body, hashlib.sha256).hexdigest()
        return hmac.compare_digest(headers.get("x-sondalog-signature", ""), good)

    def body(self, i: int) -> Any:
        return json.loads(self.requests[i][2])

    async def handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        head = await reader.readuntil(b"\r\n\r\n")
        line, *rest = head.decode().split("\r\n")
        headers = {k.lower(): v.strip() for k, _, v in (h.partition(":") for h in rest if h)}
        body = await reader.readexactly(int(headers["content-length"]))
        self.requests.append((line, headers, body))
        if self.silent:
            await asyncio.sleep(30)
        status = self.statuses.pop(0) if self.statuses else 200
        writer.write(f"HTTP/1.1 {status} X\r\nContent-Length: 0\r\n\r\n".encode())
        await writer.drain()
        writer.close()


@asynccontextmanager
async def receiving(receiver: Receiver) -> AsyncIterator[Receiver]:
    server = await asyncio.start_server(receiver.handle, "127.0.0.1", 0)
    receiver.port = server.sockets[0].getsockname()[1]
    try:
        yield receiver
    finally:
        server.close()


def hook(url: str, timeout: float = 5.0) -> Notify[WebhookSettings]:
    return Notify("hook", "webhook", WebhookSettings(url, SECRET, timeout))


MESSAGE = Message(
    key="3f2a9c1b12-1709290800000/raised/hook",
    destination="hook",
    what="raised",
    event="3f2a9c1b12-1709290800000",
    text="F01/1 Air above 40: 41.5",
    created=T0,
    next_try=T0,
    alarm="3f2a9c1b12",
    rule="hot",
    subject="F01/1",
    value=41.5,
    time=1709290800.0,
)


def test_the_post_is_signed_json_with_an_idempotency_key() -> None:
    async def run() -> Receiver:
        async with receiving(Receiver()) as rx:
            await sender_for(hook(rx.url)).send(MESSAGE)
            unsigned = Notify("plain", "webhook", WebhookSettings(rx.url, None, 5.0))
            await sender_for(unsigned).send(MESSAGE)
            return rx

    rx = asyncio.run(run())
    line, headers, _ = rx.requests[0]
    assert line == "POST /hook?x=1 HTTP/1.1"
    assert headers["content-type"] == "application/json"
    assert headers["idempotency-key"] == MESSAGE.key
    assert rx.signed(0)
    assert rx.body(0) == {
        "key": MESSAGE.key,
        "alarm": "3f2a9c1b12",
        "rule": "hot",
        "subject": "F01/1",
        "what": "raised",
        "value": 41.5,
        "time": "2024-03-01T11:00:00Z",
        "text": "F01/1 Air above 40: 41.5",
        "items": 1,
    }
    assert "x-sondalog-signature" not in rx.requests[1][1]  # no secret, no signature


def test_non_2xx_refused_and_silent_are_delivery_errors() -> None:
    async def run() -> None:
        async with receiving(Receiver(statuses=[500, 302])) as rx:
            for status in ("HTTP 500", "HTTP 302"):
                with pytest.raises(DeliveryError, match=status):
                    await sender_for(hook(rx.url)).send(MESSAGE)
        async with receiving(Receiver(silent=True)) as rx:
            with pytest.raises(DeliveryError, match=r"no answer in 0\.3 s"):
                await sender_for(hook(rx.url, timeout=0.3)).send(MESSAGE)
        gone = rx.url  # the server is closed now: the connection is refused
        with pytest.raises(DeliveryError, match=r"127\.0\.0\.1"):
            await sender_for(hook(gone)).send(MESSAGE)

    asyncio.run(run())


def test_a_receiver_failing_twice_gets_it_once_after_the_backoff() -> None:
    rx = Receiver(statuses=[503, 500])
    plan = plan_of(
        f"""
[[notify]]
name = "hook"
kind = "webhook"
url = "http://127.0.0.1:1/hook"
secret = "{SECRET}"
backoff = "10s"
[[alarm]]
name = "hot"
kind = "threshold"
above = 40
notify = ["hook"]
"""
    )
    outbox = MemoryOutbox()
    alarms, policy = Alarms(plan), Policy(plan, outbox)

    async def run() -> list[float]:
        attempts: list[float] = []
        async with receiving(rx):
            notify = plan.notify["hook"]
            sender = sender_for(replace(notify, settings=replace(notify.settings, url=rx.url)))
            now = T0
            policy.notify(alarms.reading(sample(41, 0)), now)
            while (due := outbox.next_try()) is not None:
                now = max(now, due)  # the stepped clock: straight to the next try
                for message in outbox.claim(now, "me", 120.0):
                    attempts.append(now - T0)
                    try:
                        await sender.send(message)
                    except DeliveryError as exc:
                        policy.failed(message, now, str(exc))
                    else:
                        outbox.delivered(message.key, now)
            await sender.close()
        return attempts

    attempts = asyncio.run(run())
    assert attempts == [0.0, 10.0, 30.0]  # backoff 10 s, then doubled
    assert [r[1]["idempotency-key"] for r in rx.requests] == [outbox.messages()[0].key] * 3
    assert all(rx.signed(i) for i in range(3))
    (row,) = outbox.messages()
    assert (row.state, row.attempts, row.last_error) == ("sent", 3, f"{rx.url}: HTTP 500")
