"""A logger's lines and power as the control API breaks them (issue 23).

:class:`FaultyLines` stands between a :class:`~sondalog.io.host.DeviceHost` and a logger's
engine while a line or power fault is active (the control API puts it in with
``host.replace_device`` and takes it out once every such fault is cleared, so a healthy
logger pays nothing):

- **off** (a power loss, a brown-out below the reset voltage): the module neither answers
  nor samples; its lines stay connected, what arrives on them is lost;
- **cut**: the line carries nothing either way; the module runs on;
- **noise**: each byte, with the fault's probability, has one bit flipped, is dropped or is
  sent twice (in the logger's answers, in what it receives, or both); a seeded generator
  makes a run repeatable;
- **slow**: the answers leave at the fault's baud rate (10 bits a byte, §6.11.2) after its
  latency, in order, released at the device's deadlines.

It is a :class:`~sondalog.protocol.device.Device` itself and pure: the time comes in as
``now``; line durations are in line time (``scale`` clock seconds a second, as the engine's).
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Sequence

from sondalog.app.control_actions import Noise, Slow
from sondalog.protocol.device import Device, Effect, Event, LineSend


def garble(data: bytes, noise: Noise, rng: random.Random) -> bytes:
    """``data`` with each byte, with probability ``noise.rate``, flipped, dropped or doubled."""
    rate, mode = noise.rate, noise.mode
    out = bytearray()
    draw = rng.random
    for byte in data:
        if draw() >= rate:
            out.append(byte)
            continue
        how = mode if mode != "mixed" else ("flip", "drop", "duplicate")[rng.randrange(3)]
        if how == "flip":
            out.append(byte ^ (1 << rng.randrange(8)))
        elif how == "duplicate":
            out += bytes((byte, byte))
        # drop: nothing
    return bytes(out)


class FaultyLines:
    """A device (an engine, a fleet's named engine) with its line and power faults."""

    def __init__(self, inner: Device, scale: float = 1.0) -> None:
        self.inner = inner
        self.scale = scale
        self.off = False
        self.cut = False
        self.noise: Noise | None = None
        self.slow: Slow | None = None
        self._rng = random.Random(0)
        self._held: dict[int, deque[tuple[float, LineSend]]] = {}  # line -> (release, output)
        self._free_at: dict[int, float] = {}

    @property
    def quiet(self) -> bool:
        """No fault is active: the wrapper can go."""
        return not (self.off or self.cut or self.noise or self.slow or self._held)

    def set_noise(self, noise: Noise | None) -> None:
        self.noise = noise
        self._rng = random.Random(noise.seed if noise is not None else 0)

    # -- Device ------------------------------------------------------------------------------
    def open_line(self, *, paced: bool = False) -> int:
        return self.inner.open_line(paced=paced)

    def close_line(self, line: int) -> None:
        self._held.pop(line, None)
        self._free_at.pop(line, None)
        self.inner.close_line(line)

    def line_speed(self) -> int:
        return self.inner.line_speed()

    def input_room(self, line: int) -> int | None:
        room = getattr(self.inner, "input_room", None)
        return None if room is None or self.off or self.cut else room(line)

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        if self.off or self.cut:
            return []
        noise = self.noise
        if noise is not None and noise.direction != "out":
            data = garble(data, noise, self._rng)
            if not data:
                return []
        return self._out(self.inner.receive(line, data, now), now)

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        if self.off:
            return []
        return self._out(self.inner.handle(event, now), now)

    def advance(self, now: float) -> Sequence[Effect]:
        if self.off:
            return []
        effects = list(self._out(self.inner.advance(now), now))
        for line, held in list(self._held.items()):
            while held and held[0][0] <= now:
                effects.append(held.popleft()[1])
            if not held:
                del self._held[line]
        return effects

    def next_deadline(self) -> float | None:
        if self.off:
            return None
        deadline = self.inner.next_deadline()
        for held in self._held.values():
            if deadline is None or held[0][0] < deadline:
                deadline = held[0][0]
        return deadline

    # -- the answers -------------------------------------------------------------------------
    def _out(self, effects: Sequence[Effect], now: float) -> Sequence[Effect]:
        if not (self.cut or self.noise or self.slow or self._held):
            return effects
        out: list[Effect] = []
        for effect in effects:
            if not isinstance(effect, LineSend):
                out.append(effect)
                continue
            if self.cut:
                continue
            data = effect.data
            if self.noise is not None and self.noise.direction != "in":
                data = garble(data, self.noise, self._rng)
            if not data:
                continue
            send = LineSend(effect.line, data, effect.baud)
            slow = self.slow
            if slow is None and send.line not in self._held:
                out.append(send)
                continue
            free = self._free_at.get(send.line, now)
            if slow is None:  # (the line was slow: what it still holds leaves first)
                release = free
            else:
                start = max(free, now + slow.latency * self.scale)
                release = start + len(data) * 10 / slow.baud * self.scale
            self._free_at[send.line] = release
            self._held.setdefault(send.line, deque()).append((release, send))
        return out

    def drop_held(self) -> None:
        """Forget the answers the slow line still holds (the fault ended or power was lost)."""
        self._held.clear()
        self._free_at.clear()
