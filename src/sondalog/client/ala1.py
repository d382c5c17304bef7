"""The ALA1 client: a connection to a logger (asyncio :class:`Ala1Client`, blocking
:class:`Client`) that sends command lines and reads their answers; the answer format and its
checks are in :mod:`sondalog.client.ala1_codec`."""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Callable, Iterable
from types import TracebackType
from typing import TypeVar, cast

from sondalog.client.ala1_codec import (
    DEFAULT_QUIET_PERIOD,
    DEFAULT_TIMEOUT,
    ClientError,
    ConnectionLost,
    IncompleteAnswer,
    NoAnswer,
    Request,
    Response,
    Status,
    ends_final,
    parse_answer,
    strip_sum,
)
from sondalog.client.answer_wait import read_answers
from sondalog.client.endpoints import Endpoint, parse_url

__all__ = ["Ala1Client", "Client"]

T = TypeVar("T")


class _Stream(asyncio.Protocol):
    """Received bytes, split into lines on demand. One reader waits at a time (the client's
    lock): a bare future woken by the bytes or by a timer, not a task per wait."""

    def __init__(self) -> None:
        self.buffer = bytearray()
        self.closed = False
        self._waiter: asyncio.Future[bool] | None = None
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # uvloop's transports are not asyncio.Transport subclasses: take the interface
        self.transport = cast(asyncio.Transport, transport)

    def data_received(self, data: bytes) -> None:
        self.buffer += data
        self._wake(True)

    def connection_lost(self, exc: Exception | None) -> None:
        self.closed = True
        self._wake(True)

    def _wake(self, value: bool) -> None:
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(value)

    def take_line(self) -> bytes | None:
        end = self.buffer.find(b"\n")
        if end < 0:
            return None
        line = bytes(self.buffer[: end + 1])
        del self.buffer[: end + 1]
        return line

    async def wait(self, timeout: float) -> bool:
        """Wait for more bytes (or the close); False on timeout."""
        if self.closed:
            return False
        loop = asyncio.get_running_loop()
        waiter: asyncio.Future[bool] = loop.create_future()
        self._waiter = waiter
        timer = loop.call_later(timeout, self._wake, False)
        try:
            return await waiter
        finally:
            timer.cancel()
            self._waiter = None

    async def wait_on(self, waiter: asyncio.Future[bool]) -> bool:
        """Wait with ``waiter`` in the waiter slot: told of every piece of bytes and of the
        close (its ``set_result``), it decides itself when it is done, so the reader is
        woken once (:class:`~sondalog.client.answer_wait.CountedWait`); False when closed."""
        if self.closed:
            waiter.cancel()
            return False
        self._waiter = waiter
        try:
            return await waiter
        finally:
            waiter.cancel()  # its timer, when it did not end by itself
            self._waiter = None


@functools.lru_cache(maxsize=1024)
def _plain(text: str) -> Request:
    """The request of a command line without headers, its line worked out once: a collector
    sends the same few lines at every contact."""
    return Request(text)


class Ala1Client:
    """An asyncio connection to one ALA1 logger. Commands run one at a time."""

    def __init__(self, endpoint: Endpoint, timeout: float = DEFAULT_TIMEOUT) -> None:
        self.endpoint = endpoint
        self.timeout = timeout
        self.quiet_period = DEFAULT_QUIET_PERIOD
        self._stream: _Stream | None = None
        self._lock = asyncio.Lock()

    @classmethod
    async def connect(cls, url: str | Endpoint, timeout: float = DEFAULT_TIMEOUT) -> Ala1Client:
        """Connect to ``tcp://HOST:PORT`` or ``serial:///DEVICE?baud=N`` (see
        :func:`~sondalog.client.endpoints.parse_url`)."""
        client = cls(parse_url(url) if isinstance(url, str) else url, timeout)
        _, client._stream = await client.endpoint.connect(_Stream)
        return client

    async def close(self) -> None:
        if self._stream is not None and self._stream.transport is not None:
            self._stream.transport.close()
        self._stream = None

    @property
    def open_transport(self) -> asyncio.Transport | None:
        """The connection's transport while it is open; None once it closed (or before it
        opened). For a holder that keeps the connection between uses
        (:mod:`sondalog.collect.keep_open`)."""
        stream = self._stream
        if stream is None or stream.closed or stream.transport is None:
            return None
        return None if stream.transport.is_closing() else stream.transport

    async def __aenter__(self) -> Ala1Client:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    async def command(
        self,
        text: str,
        *,
        check: bool = False,
        sum: bool = False,
        crcsum: bool = False,
        quiet: bool = False,
        timeout: float | None = None,
    ) -> Response:
        """Send one command line and return its answer (see the module docstring)."""
        request = Request(text, check, sum, crcsum, quiet)
        return (await self.pipeline([request], timeout=timeout))[0]

    async def pipeline(
        self, requests: Iterable[Request | str], *, timeout: float | None = None
    ) -> list[Response]:
        """Send several command lines at once and return their answers in order.

        The module runs them one after the other on this line, so the answers come back in
        order. ``timeout`` applies to each answer. Bytes left over from an earlier answer are
        discarded first.
        """
        stream = self._require_stream()
        reqs = [r if isinstance(r, Request) else _plain(r) for r in requests]
        payload = "".join(r.line() + "\r" for r in reqs).encode("latin-1")
        async with self._lock:
            stream.buffer.clear()
            assert stream.transport is not None
            stream.transport.write(payload)
            return [await self._read_answer(stream, r, timeout) for r in reqs]

    async def exchange(
        self, payload: bytes, parse: Callable[[bytes], T | None], *, timeout: float | None = None
    ) -> tuple[T | None, bytes]:
        """Write ``payload`` (whole command lines, each with its CR) and read until ``parse``
        makes something (not None) of every byte received, or the line stays silent for
        ``timeout`` seconds after its last byte. Returns what ``parse`` made (None when it
        never did) and the bytes received; ``parse`` may raise, a closed line raises
        :class:`ConnectionLost`. One wait per burst
        of bytes and no work per line: the collector's contact (:mod:`sondalog.client.visit`).
        Bytes left over from an earlier answer are discarded first."""
        stream = self._require_stream()
        wait = self.timeout if timeout is None else timeout
        async with self._lock:
            stream.buffer.clear()
            assert stream.transport is not None
            stream.transport.write(payload)
            while True:
                if stream.buffer:
                    raw = bytes(stream.buffer)
                    result = parse(raw)
                    if result is not None:
                        stream.buffer.clear()
                        return result, raw
                if stream.closed or not await stream.wait(wait):
                    raw = bytes(stream.buffer)
                    stream.buffer.clear()
                    if stream.closed:
                        line = payload.split(b"\r", 1)[0].decode("latin-1")
                        raise ConnectionLost.during(line, raw)
                    return None, raw

    async def _read_answer(
        self, stream: _Stream, request: Request, timeout: float | None
    ) -> Response:
        loop = asyncio.get_running_loop()
        wait = self.timeout if timeout is None else timeout
        deadline = loop.time() + wait
        lines: list[bytes] = []
        while True:
            line = stream.take_line()
            if line is not None:
                lines.append(line)
                end = line.rstrip(b"\r\n")
                if end.endswith(b"OK") or end == b"ERROR":  # only such a line can end it
                    response = parse_answer(request, lines)
                    if response is not None:
                        return response
                continue
            remaining = deadline - loop.time()
            if request.quiet:
                remaining = min(remaining, self.quiet_period)
            if stream.closed or remaining <= 0 or not await stream.wait(remaining):
                break
            deadline = loop.time() + wait  # an answer still arriving is not finished
        raw = b"".join(lines) + bytes(stream.buffer)
        stream.buffer.clear()
        if request.quiet:
            texts = [ln.decode("latin-1").rstrip("\r\n") for ln in lines]
            if request.sum:
                texts = [strip_sum(t) for t in texts]
            return Response(request.line(), tuple(texts), Status.SILENT, raw)
        if stream.closed:
            raise ConnectionLost.during(request.line(), raw)
        if not raw:
            raise NoAnswer(f"no answer to {request.line()!r}")
        raise IncompleteAnswer(f"incomplete answer to {request.line()!r}: {raw!r}", raw)

    def _require_stream(self) -> _Stream:
        if self._stream is None:
            raise ClientError("not connected")
        return self._stream

    async def exchange_raw(
        self, text: str, *, timeout: float | None = None, quiet_period: float | None = None
    ) -> bytes:
        """Send ``text`` as typed and return the raw answer, without interpreting headers.

        For terminals: the answer ends at a line that looks final (``OK``, a decorated
        ``...,OK`` or ``ERROR``), or once bytes have arrived and then ``quiet_period`` seconds
        pass in silence (``quiet``, or decorations this heuristic does not see). Returns b""
        when nothing arrives within ``timeout``. Both periods run from the last byte
        received: an answer still arriving on a slow line is never cut (issue 16); the
        caller tells a silent end from a final line with :func:`ends_final`.
        """
        stream = self._require_stream()
        if any(c in text for c in "\r\n"):
            raise ValueError("a command line may not contain CR or LF")
        loop = asyncio.get_running_loop()
        wait = self.timeout if timeout is None else timeout
        deadline = loop.time() + wait
        period = self.quiet_period if quiet_period is None else quiet_period
        async with self._lock:
            stream.buffer.clear()
            assert stream.transport is not None
            stream.transport.write(text.encode("latin-1") + b"\r")
            received = bytearray()
            while True:
                line = stream.take_line()
                if line is not None:
                    received += line
                    if ends_final(line):
                        return bytes(received)
                    continue
                remaining = deadline - loop.time()
                if received or stream.buffer:
                    remaining = min(remaining, period)
                if stream.closed or remaining <= 0 or not await stream.wait(remaining):
                    received += stream.buffer
                    stream.buffer.clear()
                    if not received and stream.closed:
                        raise ConnectionLost("connection closed")
                    return bytes(received)
                deadline = loop.time() + wait  # the timeout runs from the last byte

    async def send_raw(self, data: bytes) -> None:
        """Send bytes as they are (terminal use: partial lines, ESC, ...)."""
        stream = self._require_stream()
        assert stream.transport is not None
        stream.transport.write(data)

    async def receive_raw(self, timeout: float) -> bytes:
        """Whatever arrives within ``timeout`` (at least one chunk if any), b"" on timeout."""
        stream = self._require_stream()
        if not stream.buffer and not stream.closed:
            await stream.wait(timeout)
        data = bytes(stream.buffer)
        stream.buffer.clear()
        if not data and stream.closed:
            raise ConnectionLost("connection closed")
        return data

    async def read_counted(
        self,
        payload: bytes,
        lines: int,
        most: int,
        answered: Callable[[bytes, int], tuple[int, bool]],
        *,
        more: Iterable[tuple[int, int, bytes]] = (),
        timeout: float | None = None,
        gather: float = 0.0,
    ) -> bytes:
        """Write ``payload`` (pipelined command lines), and each of ``more``'s pieces once
        the answers are far enough; return the bytes received once they hold ``lines`` line
        ends, or once ``answered`` (asked after a refusal) says they are whole. The coroutine
        is woken once, not for each piece of the answers (``gather``: and the line read
        at most once in that many seconds meanwhile); what it raises:
        :func:`~sondalog.client.answer_wait.read_answers`. Bytes left over from an earlier
        answer are discarded first."""
        stream = self._require_stream()
        wait = self.timeout if timeout is None else timeout
        async with self._lock:
            return await read_answers(stream, payload, lines, most, answered, more, wait, gather)


class Client:
    """Blocking wrapper of :class:`Ala1Client` for scripts (not for use inside a running loop).

    >>> with Client("tcp://127.0.0.1:10001") as logger:  # doctest: +SKIP
    ...     logger.command("read i version").lines
    ('2.10',)
    """

    def __init__(self, url: str, timeout: float = DEFAULT_TIMEOUT) -> None:
        self._runner = asyncio.Runner()
        try:
            self._client = self._runner.run(Ala1Client.connect(url, timeout))
        except BaseException:
            self._runner.close()
            raise

    def command(
        self,
        text: str,
        *,
        check: bool = False,
        sum: bool = False,
        crcsum: bool = False,
        quiet: bool = False,
        timeout: float | None = None,
    ) -> Response:
        """See :meth:`Ala1Client.command`."""
        return self._runner.run(
            self._client.command(
                text, check=check, sum=sum, crcsum=crcsum, quiet=quiet, timeout=timeout
            )
        )

    def pipeline(
        self, requests: Iterable[Request | str], *, timeout: float | None = None
    ) -> list[Response]:
        """See :meth:`Ala1Client.pipeline`."""
        return self._runner.run(self._client.pipeline(requests, timeout=timeout))

    def close(self) -> None:
        try:
            self._runner.run(self._client.close())
        finally:
            self._runner.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
