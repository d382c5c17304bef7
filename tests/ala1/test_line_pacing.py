"""Serial-line behaviour of the core on a stepped clock (§6.11.1, §6.11.2, §8.5.2, §6.14.9.2)."""

from __future__ import annotations

from ala1_module import T0, Module

from sondalog.protocol.device import LineSend as Output


class PacedLine:
    """A paced line of a module: collects what leaves it and when."""

    def __init__(self, m: Module) -> None:
        self.m = m
        self.line = m.engine.open_line(paced=True)
        self.log: list[tuple[float, Output]] = []

    def send(self, data: bytes) -> None:
        self._collect(self.m.engine.receive(self.line, data, self.m.now))

    def run(self, until: float) -> bytes:
        """Step from deadline to deadline up to ``until``; returns what was sent."""
        start = len(self.log)
        while True:
            deadline = self.m.engine.next_deadline()
            if deadline is None or deadline > until:
                self.m.now = until
                self._collect(self.m.engine.advance(until))
                break
            self.m.now = max(self.m.now, deadline)
            self._collect(self.m.engine.advance(self.m.now))
        return b"".join(o.data for _, o in self.log[start:])

    def _collect(self, outputs: list[Output]) -> None:
        self.log += [(self.m.now, o) for o in outputs if o.line == self.line]


def test_output_leaves_at_ten_bit_times_per_byte() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"read text/" + b"x" * 100 + b"/\r")
    answer = line.run(T0 + 10)
    assert answer == b"x" * 100 + b"\r\nOK\r\n"  # 106 bytes at 9600 baud
    last_byte = max(t for t, o in line.log)
    assert abs((last_byte - T0) - 106 * 10 / 9600) < 0.011
    assert all(o.baud == 9600 for _, o in line.log)


def test_comspeed_switches_for_one_answer_and_returns() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"comspeed 115200 read text/" + b"y" * 50 + b"/\rread text/z/\r")
    line.run(T0 + 5)
    bauds = [(o.baud, o.data[-4:]) for _, o in line.log]
    assert bauds[0][0] == 115200 and b"".join(o.data for _, o in line.log).endswith(b"z\r\nOK\r\n")
    assert line.log[-1][1].baud == 9600
    fast = sum(len(o.data) for _, o in line.log if o.baud == 115200)
    assert fast == 56


def test_written_com_speed_takes_effect_after_its_ok() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"write com speed 19200\r")
    line.run(T0 + 1)
    assert [(o.data, o.baud) for _, o in line.log] == [(b"OK\r\n", 9600)]
    line.send(b"read nothing\r")
    line.run(T0 + 2)
    assert line.log[-1][1].baud == 19200


def test_xoff_stops_output_and_xon_resumes() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"read text/" + b"a" * 90 + b"/\r")
    line.run(T0 + 0.05)  # about 48 bytes out
    line.send(b"\x13")
    sent = sum(len(o.data) for _, o in line.log)
    assert 0 < sent < 96
    assert line.run(T0 + 30) == b""  # stopped
    line.send(b"\x11")
    rest = line.run(T0 + 31)
    assert sent + len(rest) == 96 and rest.endswith(b"OK\r\n")


def test_after_60_seconds_stopped_flow_control_is_ignored_until_xon() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"\x13")  # XOFF before anything was sent
    line.send(b"read i version\r")
    assert line.run(T0 + 59.9) == b""
    assert line.run(T0 + 61) == b"2.10\r\nOK\r\n"  # 60 s stopped: sent anyway
    line.send(b"\x13")  # ignored now ...
    line.send(b"read i version\r")
    assert line.run(T0 + 62) == b"2.10\r\nOK\r\n"
    line.send(b"\x11\x13")  # ... until an XON: then XOFF works again
    line.send(b"read i version\r")
    assert line.run(T0 + 63) == b""


def test_flow_control_bytes_inside_a_command_are_not_text() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"read i\x13\x11 version\r")
    assert line.run(T0 + 1) == b"2.10\r\nOK\r\n"


def test_messages_are_blocked_from_the_first_command_until_com_close_or_disconnect() -> None:
    m = Module()
    assert not m.engine.messages_blocked
    other = m.engine.open_line()
    assert not m.engine.messages_blocked  # connected, but no command yet
    m.ask("read nothing")
    assert m.engine.messages_blocked
    m.ok("write com close")
    assert not m.engine.messages_blocked
    m.engine.receive(other, b"read nothing\r", m.now)
    assert m.engine.messages_blocked
    m.engine.close_line(other)
    assert not m.engine.messages_blocked


def test_output_pending_until_the_last_byte_left() -> None:
    m = Module()
    line = PacedLine(m)
    line.send(b"read i version\r")
    assert m.engine.output_pending(line.line)
    line.run(T0 + 1)
    assert not m.engine.output_pending(line.line)
    assert not m.engine.output_pending(999)  # an unknown line has nothing pending
