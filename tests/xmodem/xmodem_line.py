"""An in-memory serial line between two pure XMODEM ends, on a stepped clock.

Each direction is a :class:`Wire` that may damage individual writes (a write is whatever one
end returned from one call): drop it, flip a byte, cut its tail, deliver it twice, replace it
with noise, or let it trickle in pieces. Bytes due at the same moment reach the far end in one
``receive`` call, as one ``read()`` of a real line returns everything buffered.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise
from typing import Literal, Protocol

FaultKind = Literal["drop", "flip", "truncate", "duplicate", "split", "garble"]


@dataclass(frozen=True)
class Fault:
    """Damage to the ``index``-th non-empty write in one direction."""

    index: int
    kind: FaultKind
    pos: int = 0
    """Byte position (taken modulo the write's length)."""
    mask: int = 0x55
    """XOR mask for ``flip`` (non-zero), replacement byte for ``garble``."""
    pieces: tuple[int, ...] = ()
    """Cut points for ``split`` (taken modulo the write's length)."""


class End(Protocol):
    """What the simulation needs from an XMODEM end."""

    @property
    def done(self) -> bool: ...

    def start(self, now: float) -> bytes: ...

    def receive(self, data: bytes, now: float) -> bytes: ...

    def advance(self, now: float) -> bytes: ...

    def next_deadline(self) -> float | None: ...


@dataclass
class Wire:
    """One direction of the line."""

    latency: float = 0.0
    faults: dict[int, Fault] = field(default_factory=dict)
    gap: float = 0.002
    """Time between the pieces of a split write (far below the 1 s inter-byte timeout)."""
    writes: int = 0
    carried: int = 0
    queue: list[tuple[float, bytes]] = field(default_factory=list)

    def write(self, data: bytes, now: float) -> None:
        if not data:
            return
        fault = self.faults.get(self.writes)
        self.writes += 1
        self.carried += len(data)
        at = now + self.latency
        if fault is None:
            self.queue.append((at, data))
        elif fault.kind == "drop":
            pass
        elif fault.kind == "flip":
            i = fault.pos % len(data)
            self.queue.append((at, data[:i] + bytes([data[i] ^ fault.mask]) + data[i + 1 :]))
        elif fault.kind == "garble":
            i = fault.pos % len(data)
            self.queue.append((at, data[:i] + bytes([fault.mask]) + data[i + 1 :]))
        elif fault.kind == "truncate":
            self.queue.append((at, data[: fault.pos % len(data)]))
        elif fault.kind == "duplicate":
            self.queue.append((at, data + data))
        else:
            cuts = sorted({p % len(data) for p in fault.pieces} | {0, len(data)})
            for n, (a, b) in enumerate(pairwise(cuts)):
                self.queue.append((at + n * self.gap, data[a:b]))

    def take(self, now: float) -> bytes:
        due = [d for t, d in self.queue if t <= now]
        self.queue = [(t, d) for t, d in self.queue if t > now]
        return b"".join(due)

    def next_time(self) -> float | None:
        return min((t for t, _ in self.queue), default=None)


@dataclass
class Outcome:
    now: float
    steps: int


def run(
    sender: End,
    receiver: End,
    s2r: Wire | None = None,
    r2s: Wire | None = None,
    *,
    limit: float = 3600.0,
    cancel_at: tuple[str, float] | None = None,
) -> Outcome:
    """Run both ends until both are done (or the stepped clock reaches ``limit``).

    ``cancel_at`` = (``"sender"`` | ``"receiver"``, time) cancels that end at that time.
    """
    s2r = s2r or Wire()
    r2s = r2s or Wire()
    now = 0.0
    r2s.write(receiver.start(now), now)
    s2r.write(sender.start(now), now)
    steps = 0
    while steps < 1_000_000:
        steps += 1
        if cancel_at is not None and now >= cancel_at[1]:
            who, _ = cancel_at
            cancel_at = None
            if who == "sender":
                s2r.write(sender.cancel(), now)  # type: ignore[attr-defined]
            else:
                r2s.write(receiver.cancel(), now)  # type: ignore[attr-defined]
        chunk = s2r.take(now)
        if chunk:
            r2s.write(receiver.receive(chunk, now), now)
        chunk = r2s.take(now)
        if chunk:
            s2r.write(sender.receive(chunk, now), now)
        r2s.write(receiver.advance(now), now)
        s2r.write(sender.advance(now), now)
        if sender.done and receiver.done and not s2r.queue and not r2s.queue:
            break
        times = [
            t
            for t in (
                s2r.next_time(),
                r2s.next_time(),
                sender.next_deadline(),
                receiver.next_deadline(),
                cancel_at[1] if cancel_at else None,
            )
            if t is not None
        ]
        if not times:
            break
        now = max(now, min(times))
        if now > limit:
            break
    return Outcome(now, steps)
