"""The shared half-duplex RS-485 line, as a pure timing model (no I/O, time is a parameter).

Each byte takes 10 bit times (8N1: start, 8 data, stop) at the baud rate. A node's UART sends
its transmissions one after the other; different nodes do not listen before talking, so two
transmissions that overlap in time corrupt each other: every byte of either one that
overlaps the other in time is received as a garbled byte with the high bit set, which no frame
may contain, so both frames fail (hctmps1.md §2: bad frames get no reply). Optional noise flips
each data bit with a given probability (bit error rate), the same for every receiver.

Received bytes are handed out in chunks ending at a line feed or at the end of a transmission:
receivers only act on whole lines, so this is as good as byte-by-byte delivery and much
cheaper. A byte is handed out only once its stop bit has passed, when nothing that starts
later can overlap it any more.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

BITS_PER_BYTE = 10


def byte_time(baud: int) -> float:
    """Seconds one byte occupies the line (8N1)."""
    return BITS_PER_BYTE / baud


@dataclass
class Transmission:
    """One burst of bytes from one node."""

    sender: int
    start: float
    byte_time: float
    data: bytearray
    delivered: int = 0
    marks: list[int] = field(default_factory=list)  # indices after which to deliver

    @property
    def end(self) -> float:
        return self.start + len(self.data) * self.byte_time

    def byte_end(self, index: int) -> float:
        """When byte ``index`` has been fully received."""
        return self.start + (index + 1) * self.byte_time

    def garble(self, first: float, last: float) -> int:
        """Garble the bytes that overlap ``[first, last)`` in time; return how many."""
        lo = max(0, int((first - self.start) / self.byte_time))
        hi = min(len(self.data), int((last - self.start) / self.byte_time) + 1)
        count = 0
        for i in range(lo, hi):
            b_start = self.start + i * self.byte_time
            if b_start < last and b_start + self.byte_time > first:
                self.data[i] = (self.data[i] ^ 0x55) | 0x80
                count += 1
        return count


class Medium:
    """The line: who is transmitting when, and what receivers get."""

    def __init__(self, baud: int, bit_error_rate: float = 0.0, rng: random.Random | None = None):
        if baud <= 0:
            raise ValueError("baud must be positive")
        if not 0 <= bit_error_rate < 1:
            raise ValueError("the bit error rate must be in [0, 1)")
        self.baud = baud
        self.byte_time = byte_time(baud)
        self.bit_error_rate = bit_error_rate
        self._rng = rng or random.Random(0)
        self._active: list[Transmission] = []
        self._busy_until: dict[int, float] = {}
        self.collisions = 0
        self.bit_errors = 0
        self.bytes_sent = 0

    def transmit(self, sender: int, data: bytes, now: float) -> Transmission:
        """Queue ``data`` on ``sender``'s UART; it starts at ``now`` or when the UART is free."""
        start = max(now, self._busy_until.get(sender, now))
        tx = Transmission(sender, start, self.byte_time, bytearray(data))
        tx.marks = [i for i, b in enumerate(data) if b == 0x0A]
        if not tx.marks or tx.marks[-1] != len(data) - 1:
            tx.marks.append(len(data) - 1)
        self._add_noise(tx)
        for other in self._active:
            if other.sender != sender and other.start < tx.end and tx.start < other.end:
                first, last = max(tx.start, other.start), min(tx.end, other.end)
                if tx.garble(first, last) + other.garble(first, last):
                    self.collisions += 1
        self._active.append(tx)
        self._busy_until[sender] = tx.end
        self.bytes_sent += len(data)
        return tx

    def _add_noise(self, tx: Transmission) -> None:
        if self.bit_error_rate <= 0:
            return
        rng = self._rng
        for i in range(len(tx.data)):
            for bit in range(8):
                if rng.random() < self.bit_error_rate:
                    tx.data[i] ^= 1 << bit
                    self.bit_errors += 1

    def busy(self, now: float) -> bool:
        """True if some node is transmitting at ``now``."""
        return any(tx.start <= now < tx.end for tx in self._active)

    def next_deadline(self) -> float | None:
        """When the next chunk of received bytes is ready."""
        best: float | None = None
        for tx in self._active:
            mark = next(m for m in tx.marks if m >= tx.delivered)
            when = tx.byte_end(mark)
            if best is None or when < best:
                best = when
        return best

    def receive(self, now: float) -> list[tuple[int, bytes]]:
        """The chunks complete by ``now``, as ``(sender, bytes)`` in time order."""
        chunks: list[tuple[float, int, bytes]] = []
        keep: list[Transmission] = []
        for tx in self._active:
            while tx.delivered < len(tx.data):
                mark = next(m for m in tx.marks if m >= tx.delivered)
                when = tx.byte_end(mark)
                if when > now + 1e-12:
                    break
                chunks.append((when, tx.sender, bytes(tx.data[tx.delivered : mark + 1])))
                tx.delivered = mark + 1
            if tx.delivered < len(tx.data):
                keep.append(tx)
        self._active = keep
        chunks.sort(key=lambda c: c[0])
        return [(sender, data) for _, sender, data in chunks]
