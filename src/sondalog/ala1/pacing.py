"""Output of one line at its baud rate, with XON/XOFF flow control (§6.11.1, §6.11.2, §8.5.2).

A byte takes 10 bit times on an 8N1 line (start bit, 8 data bits, stop bit). The pacer holds
what the module sends and releases each byte when its transmission has finished, so a host
reading a pty sees the timing of a real serial line. XOFF stops the output and XON resumes
it; after 60 s stopped, the module ignores flow control until the next XON.

Unpaced lines (TCP without ``--line-rate``) release bytes at once but still obey XOFF.
Pure: time comes in as an argument; :meth:`Pacer.next_deadline` says when to call again.
"""

from __future__ import annotations

from collections import deque

#: §6.11.1: after this long stopped by XOFF the module sends anyway.
FLOW_OVERRIDE = 60.0
#: Wake-ups are grouped to at least this much line time (a few bytes at low rates).
GRANULE = 0.01


class Pacer:
    """The transmitter of one line."""

    def __init__(self, paced: bool = True) -> None:
        self.paced = paced
        self._queue: deque[tuple[bytes, int | None]] = deque()  # (data, baud) chunks
        self._offset = 0  # bytes of the first chunk already sent
        self._free_at = 0.0  # when the line finishes the last byte released
        self._stopped_at: float | None = None  # XOFF received and obeyed
        self._ignoring = False  # stopped too long: flow control ignored until XON
        self.sent = 0

    # -- flow control ----------------------------------------------------------------------
    def xoff(self, now: float) -> None:
        if not self._ignoring and self._stopped_at is None:
            self._stopped_at = now

    def xon(self, now: float) -> None:
        self._ignoring = False
        if self._stopped_at is not None:
            self._stopped_at = None
            self._free_at = max(self._free_at, now)

    def _check_override(self, now: float) -> None:
        if self._stopped_at is not None and now - self._stopped_at >= FLOW_OVERRIDE:
            self._free_at = max(self._free_at, self._stopped_at + FLOW_OVERRIDE)
            self._stopped_at = None
            self._ignoring = True

    # -- output ------------------------------------------------------------------------------
    def push(self, data: bytes, baud: int | None, now: float) -> None:
        """Queue ``data`` to be sent at ``baud`` (None: as fast as the line takes it)."""
        if not data:
            return
        if not self._queue:
            self._free_at = max(self._free_at, now)
        self._queue.append((data, baud))

    def idle(self) -> bool:
        """Nothing queued and not stopped by XOFF: no output and no deadline."""
        return not self._queue and self._stopped_at is None

    def quiet(self) -> bool:
        """Unpaced and :meth:`idle`: what is sent now leaves at once, nothing before it."""
        return not self.paced and self.idle()

    def pending(self) -> int:
        return sum(len(d) for d, _ in self._queue) - self._offset

    def take(self, now: float) -> list[tuple[bytes, int | None]]:
        """The bytes whose transmission has finished by ``now``, as (bytes, baud) pieces."""
        self._check_override(now)
        if self._stopped_at is not None:
            return []
        pieces: list[tuple[bytes, int | None]] = []
        while self._queue:
            data, baud = self._queue[0]
            remaining = len(data) - self._offset
            if baud is None or not self.paced:
                count = remaining
            else:
                byte_time = 10.0 / baud
                # 1 % of a byte of slack: clock values near 1e9 s carry ~1e-7 s of rounding
                count = min(remaining, int((now - self._free_at) / byte_time + 0.01))
                self._free_at += count * byte_time
            if count:
                piece = data[self._offset : self._offset + count]
                if pieces and pieces[-1][1] == baud:
                    pieces[-1] = (pieces[-1][0] + piece, baud)
                else:
                    pieces.append((piece, baud))
                self.sent += count
            self._offset += count
            if self._offset < len(data):
                break
            self._queue.popleft()
            self._offset = 0
        return pieces

    def next_deadline(self) -> float | None:
        """When :meth:`take` will have something (or the XOFF override runs out)."""
        if self._stopped_at is not None:
            return self._stopped_at + FLOW_OVERRIDE
        if not self._queue:
            return None
        data, baud = self._queue[0]
        if baud is None or not self.paced:
            return self._free_at
        byte_time = 10.0 / baud
        remaining = len(data) - self._offset
        batch = max(1, min(remaining, int(GRANULE / byte_time)))
        return self._free_at + batch * byte_time
