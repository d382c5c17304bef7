"""A real SMTP server (aiosmtpd, recipes.md §4) in a thread of its own, for the collector's
alarm tests: it keeps every message it takes, and can hold its answer to DATA (the
collector is then killed in the middle of a delivery)."""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from email import message_from_bytes
from email.message import Message

from aiosmtpd.smtp import SMTP, Envelope, Session


class MailSink:
    """Every message taken, in order; ``hold``: seconds to wait before answering DATA;
    ``entered``: set when a DATA answer is being held."""

    def __init__(self) -> None:
        self.mails: list[Message] = []
        self.hold = 0.0
        self.entered = threading.Event()
        self.port = 0
        self._lock = threading.Lock()

    async def handle_DATA(self, server: SMTP, session: Session, envelope: Envelope) -> str:
        data = envelope.content if isinstance(envelope.content, bytes) else b""
        with self._lock:
            self.mails.append(message_from_bytes(data))
        if self.hold:
            self.entered.set()
            await asyncio.sleep(self.hold)
        return "250 OK"

    def sent_keys(self) -> list[str]:
        with self._lock:
            return [str(m["X-Sondalog-Key"]) for m in self.mails]

    def subjects(self) -> list[str]:
        with self._lock:
            return [str(m["Subject"]) for m in self.mails]

    def wait(self, condition: Callable[[], bool], timeout: float = 20.0) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out; mails: {self.subjects()}")
            time.sleep(0.05)


@contextlib.contextmanager
def smtp_server() -> Iterator[MailSink]:
    sink = MailSink()
    loop = asyncio.new_event_loop()
    ready = threading.Event()
    servers: list[asyncio.Server] = []

    async def start() -> None:
        srv = await asyncio.get_running_loop().create_server(lambda: SMTP(sink), "127.0.0.1", 0)
        sink.port = srv.sockets[0].getsockname()[1]
        servers.append(srv)
        ready.set()

    def main() -> None:
        loop.run_until_complete(start())
        loop.run_forever()

    thread = threading.Thread(target=main, daemon=True)
    thread.start()
    assert ready.wait(10)
    try:
        yield sink
    finally:

        async def stop() -> None:
            for srv in servers:
                srv.close()

        asyncio.run_coroutine_threadsafe(stop(), loop).result(5)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)
