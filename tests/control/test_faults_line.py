"""FaultyLines as a pure device on a stepped clock: a slow line releases everything, in
order, at its baud rate; a cut or a power loss passes nothing; clearing lets it all through."""

from __future__ import annotations

from collections.abc import Sequence

from hypothesis import given
from hypothesis import strategies as st

from sondalog.app.control_actions import Slow
from sondalog.app.faults_line import FaultyLines
from sondalog.protocol.device import Effect, Event, LineSend


class Echo:
    """A device answering every input at once, on the line it came from."""

    def __init__(self) -> None:
        self.lines = 0
        self.received: list[bytes] = []

    def open_line(self, *, paced: bool = False) -> int:
        self.lines += 1
        return self.lines

    def close_line(self, line: int) -> None:
        pass

    def line_speed(self) -> int:
        return 9600

    def receive(self, line: int, data: bytes, now: float) -> Sequence[Effect]:
        self.received.append(data)
        return [LineSend(line, data)]

    def handle(self, event: Event, now: float) -> Sequence[Effect]:
        return []

    def advance(self, now: float) -> Sequence[Effect]:
        return []

    def next_deadline(self) -> float | None:
        return None


def _run_until_quiet(device: FaultyLines, now: float, out: list[tuple[float, bytes]]) -> float:
    """Step the clock to each deadline the device gives until it has none (liveness)."""
    for _ in range(10_000):
        deadline = device.next_deadline()
        if deadline is None:
            return now
        assert deadline >= now - 1e-9
        now = deadline
        out += [(now, e.data) for e in device.advance(now) if isinstance(e, LineSend)]
    raise AssertionError("the slow line never emptied")


@given(
    chunks=st.lists(st.binary(min_size=1, max_size=40), min_size=1, max_size=20),
    baud=st.integers(10, 230400),
    latency=st.floats(0, 5),
    gaps=st.lists(st.floats(0, 3), min_size=20, max_size=20),
)
def test_a_slow_line_releases_everything_in_order_at_its_rate(
    chunks: list[bytes], baud: int, latency: float, gaps: list[float]
) -> None:
    device = FaultyLines(Echo())
    line = device.open_line()
    device.slow = Slow(baud, latency)
    now, out = 0.0, []
    sent_at = []
    for chunk, gap in zip(chunks, gaps, strict=False):
        now += gap
        sent_at.append(now)
        assert device.receive(line, chunk, now) == []  # held, not sent at once
        out += [(now, e.data) for e in device.advance(now) if isinstance(e, LineSend)]
    _run_until_quiet(device, now, out)
    assert b"".join(d for _, d in out) == b"".join(chunks)  # all of it, in order
    # no byte leaves before its time: latency, then 10 bits a byte after the previous
    free = 0.0
    for (at, data), sent in zip(out, sent_at, strict=True):
        free = max(free, sent + latency) + len(data) * 10 / baud
        assert at >= free - 1e-6


def test_cut_and_power_off_pass_nothing_and_clearing_lets_it_through() -> None:
    echo = Echo()
    device = FaultyLines(echo)
    line = device.open_line()
    device.cut = True
    assert device.receive(line, b"read date\r", 0.0) == []
    assert echo.received == []  # the module never saw it
    device.cut = False
    device.off = True
    assert device.receive(line, b"read date\r", 1.0) == []
    assert device.next_deadline() is None and device.advance(2.0) == []
    device.off = False
    assert device.quiet
    assert device.receive(line, b"x\r", 3.0) == [LineSend(line, b"x\r")]


def test_clearing_a_slow_line_keeps_the_order_of_what_it_held() -> None:
    device = FaultyLines(Echo())
    line = device.open_line()
    device.slow = Slow(100, 0.0)  # 10 bytes a second
    device.receive(line, b"0123456789", 0.0)  # leaves at 1.0
    device.slow = None
    assert device.receive(line, b"later", 0.5) == []  # behind what is held
    out: list[tuple[float, bytes]] = []
    _run_until_quiet(device, 0.5, out)
    assert [d for _, d in out] == [b"0123456789", b"later"]
    assert device.quiet
