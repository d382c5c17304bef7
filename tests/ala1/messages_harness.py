"""Helpers of the message tests: step a module through its deadlines, see what it sends."""

from __future__ import annotations

from ala1_module import Module

from sondalog.ala1.outbox import Outgoing


def run_for(m: Module, seconds: float) -> list[tuple[float, bytes]]:
    """Step the clock from deadline to deadline for ``seconds``; every output with the time
    (seconds after the start of the run) it appeared at."""
    start = m.now
    end = start + seconds
    seen: list[tuple[float, bytes]] = []
    while True:
        deadline = m.engine.next_deadline()
        if deadline is None or deadline > end:
            break
        step = max(deadline - m.now, 0.0)
        data = m.advance(step)
        if data:
            seen.append((m.now - start, data))
        assert len(seen) < 10_000
    m.advance(end - m.now)
    return seen


def bodies(seen: list[tuple[float, bytes]]) -> list[bytes]:
    return [data for _, data in seen]


def released(m: Module, command: str) -> None:
    """Run ``command`` on the harness line and release the line again (§6.11.8)."""
    assert m.ask(command + " write com close").endswith(b"OK\r\n"), command


def queued(m: Module) -> list[Outgoing]:
    """Take every sending from the module's outbox (as a carrier would), oldest first."""
    out = []
    while (outgoing := m.engine.outbox.take()) is not None:
        out.append(outgoing)
    return out
