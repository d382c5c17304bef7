"""The virtual bus as a discrete-event model: a medium, modules and host ports (pure).

:class:`BusCore` owns a :class:`~sondalog.world.medium.Medium` and the
:class:`~sondalog.hctmps1.Hctmps1Module` cores attached to it. Hosts reach it through *ports*
(node numbers): :meth:`BusCore.write` puts a host's bytes on the line, :meth:`BusCore.advance`
runs every event up to a time, in time order and each at its own time, and returns what the
ports received. So timing stays exact even when the asyncio runner wakes up late, and the same
model runs on a real, accelerated or stepped clock.

A module answers ``turnaround`` seconds after the end of the frame it answers (its firmware
needs a moment to switch its RS-485 driver on).
"""

from __future__ import annotations

import random
from collections import defaultdict
from dataclasses import dataclass

from sondalog.hctmps1.module import Hctmps1Module
from sondalog.protocol.device import Event, LineSend
from sondalog.protocol.hctmps1_frames import TURNAROUND
from sondalog.world.medium import Medium

#: Module reply turnaround, seconds (docs/hctmps1.md "Decisions").
DEFAULT_TURNAROUND = TURNAROUND


@dataclass
class _Attached:
    node: int
    module: Hctmps1Module
    deadline: float | None


class BusCore:
    """Medium + modules + host ports, driven by explicit times."""

    def __init__(
        self,
        baud: int,
        bit_error_rate: float = 0.0,
        rng: random.Random | None = None,
        turnaround: float = DEFAULT_TURNAROUND,
    ) -> None:
        self.medium = Medium(baud, bit_error_rate, rng)
        self.turnaround = turnaround
        self.modules: list[_Attached] = []
        self.ports: set[int] = set()
        self._next_node = 0
        self.now = float("-inf")

    @property
    def baud(self) -> int:
        return self.medium.baud

    def _node(self) -> int:
        self._next_node += 1
        return self._next_node

    def add_module(self, module: Hctmps1Module) -> int:
        """Attach a module; it starts listening at once."""
        node = self._node()
        self.modules.append(_Attached(node, module, module.next_deadline()))
        return node

    def add_port(self) -> int:
        """Attach a host port (a gateway, a pty, a serial line); returns its node."""
        node = self._node()
        self.ports.add(node)
        return node

    def remove_port(self, node: int) -> None:
        self.ports.discard(node)

    def module(self, module_id: str) -> Hctmps1Module:
        """The module that answers to ``module_id`` now."""
        for attached in self.modules:
            if attached.module.module_id == module_id:
                return attached.module
        raise KeyError(module_id)

    def write(self, port: int, data: bytes, now: float) -> dict[int, bytes]:
        """A host sends ``data`` at ``now``; returns what ports received up to ``now``."""
        received = self.run_until(now)
        if data:
            self.medium.transmit(port, data, max(now, self.now))
        return received

    def next_deadline(self) -> float | None:
        """When the bus next has something to do."""
        deadlines = [a.deadline for a in self.modules if a.deadline is not None]
        medium = self.medium.next_deadline()
        if medium is not None:
            deadlines.append(medium)
        return min(deadlines) if deadlines else None

    def run_until(self, now: float) -> dict[int, bytes]:
        """Run every event due by ``now``; return the bytes each port received."""
        received: dict[int, bytearray] = defaultdict(bytearray)
        while (when := self.next_deadline()) is not None and when <= now:
            self._run(when, received)
        self.now = max(self.now, now)
        return {port: bytes(data) for port, data in received.items()}

    # -- the Device contract (sondalog.protocol.device): lines are host ports ----------------
    def open_line(self, *, paced: bool = False) -> int:
        """A host port; the medium itself times every byte, so ``paced`` changes nothing."""
        return self.add_port()

    def close_line(self, line: int) -> None:
        self.remove_port(line)

    def line_speed(self) -> int:
        return self.baud

    def receive(self, line: int, data: bytes, now: float) -> list[LineSend]:
        return _sends(self.write(line, data, now))

    def handle(self, event: Event, now: float) -> list[LineSend]:
        return []

    def advance(self, now: float) -> list[LineSend]:
        return _sends(self.run_until(now))

    def _run(self, when: float, received: dict[int, bytearray]) -> None:
        self.now = max(self.now, when)
        for sender, chunk in self.medium.receive(when):
            for port in self.ports:
                if port != sender:
                    received[port] += chunk
            for attached in self.modules:
                if attached.node != sender:
                    self._feed(attached, chunk, when)
        for attached in self.modules:
            if attached.deadline is not None and attached.deadline <= when:
                self._feed(attached, b"", when)

    def _feed(self, attached: _Attached, data: bytes, when: float) -> None:
        out = attached.module.handle(data, when)
        attached.deadline = out.deadline
        if out.data:
            self.medium.transmit(attached.node, out.data, when + self.turnaround)


def _sends(received: dict[int, bytes]) -> list[LineSend]:
    return [LineSend(port, data) for port, data in received.items()]
