"""The common part of the line-based mail client cores (SMTP, POP3), sans-I/O.

The shape is h11's: the caller feeds bytes with :meth:`LineClient.receive_data` (``b""``
means the peer closed the connection), sends whatever :meth:`LineClient.data_to_send`
returns, reads results with :meth:`LineClient.next_event`, and calls
:meth:`LineClient.handle_timeout` once the time passes :attr:`LineClient.deadline`. Time is
always given by the caller (any monotonic clock, in seconds); the core never reads a clock.
When :attr:`LineClient.wants_close` is true the caller closes the connection. The end of the
conversation is :attr:`LineClient.result` (also the last event).
"""

from __future__ import annotations

from collections import deque
from typing import Generic, TypeVar

MAX_LINE = 4096  # longest server line accepted (RFC 5321 allows 512, RFC 2449 512)

R = TypeVar("R")


class LineClient(Generic[R]):
    """Buffers, line splitting, one deadline, an event queue, the closing flag, the result."""

    def __init__(self, timeout: float) -> None:
        if timeout <= 0:
            raise ValueError("timeout must be positive")
        self.timeout = timeout
        self._in = bytearray()
        self._out = bytearray()
        self._events: deque[object] = deque()
        self._deadline: float | None = None
        self._started = False
        self.wants_close = False
        self.max_line = MAX_LINE
        self.result: R | None = None

    # -- the caller's side -------------------------------------------------------------
    def start(self, now: float) -> None:
        """The connection is open: wait for the server's greeting from ``now``."""
        if not self._started:
            self._started = True
            self._deadline = now + self.timeout

    @property
    def deadline(self) -> float | None:
        """When :meth:`handle_timeout` must be called, or ``None`` when nothing is awaited."""
        return None if self.wants_close else self._deadline

    def data_to_send(self) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        return out

    def next_event(self) -> object | None:
        return self._events.popleft() if self._events else None

    def receive_data(self, data: bytes, now: float) -> None:
        """Bytes from the server; ``b""`` when the server closed the connection."""
        if self.wants_close:
            return
        self.start(now)
        if self._deadline is not None and now >= self._deadline:
            self._timed_out(now)  # late bytes do not count
            return
        if not data:
            self._closed_by_peer()
            return
        self._in += data
        self._lines(now)
        if len(self._in) > self.max_line and not self.wants_close:
            self._broken("server line too long")

    def handle_timeout(self, now: float) -> None:
        if self._deadline is not None and now >= self._deadline and not self.wants_close:
            self._timed_out(now)

    def connection_failed(self, why: str) -> None:
        """The transport could not connect (or broke): the result is ``broken``."""
        self._broken(why)

    # -- for subclasses ----------------------------------------------------------------
    def _lines(self, now: float) -> None:
        while not self.wants_close:
            end = self._in.find(b"\n")
            if end < 0:
                return
            line = bytes(self._in[:end]).rstrip(b"\r")
            del self._in[: end + 1]
            self._line(line, now)

    def _send(self, data: bytes, now: float, timeout: float | None = None) -> None:
        self._out += data
        self._deadline = now + (self.timeout if timeout is None else timeout)

    def _close(self) -> None:
        self.wants_close = True
        self._deadline = None

    def _emit(self, event: object) -> None:
        self._events.append(event)

    def _finish(self, result: R) -> None:
        if self.result is None:
            self.result = result
            self._emit(result)

    def _line(self, line: bytes, now: float) -> None:
        raise NotImplementedError

    def _timed_out(self, now: float) -> None:
        raise NotImplementedError

    def _closed_by_peer(self) -> None:
        raise NotImplementedError

    def _broken(self, why: str) -> None:
        raise NotImplementedError
