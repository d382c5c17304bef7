"""The line's time base on a stepped clock (docs/decisions.md "Time base"): with a line time
scale S (``--speed S``), line durations take S clock seconds; the module's work does not."""

from __future__ import annotations

from ala1_module import T0

from sondalog.ala1 import Engine, Identity
from sondalog.backends.store.ala1_nv import SqliteNvStore

SCALE = 100.0


def _engine() -> Engine:
    return Engine(Identity(), SqliteNvStore(":memory:"), T0, line_time_scale=SCALE)


def test_the_entry_timeout_is_sixty_real_seconds() -> None:
    engine = _engine()
    line = engine.open_line()
    engine.receive(line, b"+read da", T0)
    assert engine.next_deadline() == T0 + 60 * SCALE
    assert engine.advance(T0 + 59 * SCALE) == []
    assert b"BREAK" in b"".join(o.data for o in engine.advance(T0 + 60 * SCALE))


def test_pacing_is_real_line_time() -> None:
    engine = _engine()
    line = engine.open_line(paced=True)
    engine.receive(line, b"read i version\r", T0)  # "2.10\r\nOK\r\n": 10 bytes at 9600 baud
    sent = b""
    now = T0
    while (deadline := engine.next_deadline()) is not None and len(sent) < 10:
        now = deadline
        sent += b"".join(o.data for o in engine.advance(now))
    assert sent == b"2.10\r\nOK\r\n"
    assert abs((now - T0) - 10 * 10 / 9600 * SCALE) < 0.011 * SCALE


def test_pause_is_line_time_but_sampling_is_module_time() -> None:
    engine = _engine()
    line = engine.open_line()
    engine.receive(line, b"write channel 1 sampling period 000010\r", T0)
    engine.receive(line, b"pause 2 read i version\r", T0)
    answered = b""
    wakeups = 0
    while (deadline := engine.next_deadline()) is not None and deadline < T0 + 2 * SCALE:
        wakeups += 1
        answered += b"".join(o.data for o in engine.advance(deadline) if o.line == line)
    assert answered == b""  # the pause lasts 2 s of line time = 200 clock seconds
    assert wakeups >= 19  # while sampling every 10 clock seconds
    answered = b"".join(o.data for o in engine.advance(T0 + 2 * SCALE) if o.line == line)
    assert answered == b"2.10\r\nOK\r\n"
