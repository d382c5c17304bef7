"""A whole command line sent at once (the engine's plain-line path, issue 11) gets exactly
what the same bytes get when they come one at a time through the line discipline."""

from __future__ import annotations

from ala1_module import Module
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import sine

LINES = (
    "read i version",
    "read channel value",
    "read channel 1 value",
    "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
    "write channel 2 switch output 2 write channel 2 switch advance 1",
    "write channel max number 2",
    "write channel value",
    "read record 3 from start",
    "pause 1 read date",
    "counter 2 date read i version",
    "write i name/north/",
    "read i name",
    "read xyz",
    "write com close",
    "quiet read nothing here",
    "",
    "   ",
    "read text/" + "x" * 110 + "/",
)


def module() -> Module:
    return Module(hardware=SimHardware(analog=[Analog(16, sine(1.0, 0.5, 600.0, 0.0, 0.0))]))


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(
        st.tuples(st.sampled_from(LINES), st.sampled_from((b"\r", b"\r\n")), st.floats(0, 3)),
        min_size=1,
        max_size=12,
    )
)
def test_a_whole_line_is_answered_as_its_bytes_one_by_one(
    steps: list[tuple[str, bytes, float]],
) -> None:
    whole, bytewise = module(), module()
    for text, end, pause in steps:
        data = text.encode() + end
        got = whole.feed(data)
        expected = b"".join(bytewise.feed(data[i : i + 1]) for i in range(len(data)))
        got += whole.advance(pause)
        expected += bytewise.advance(pause)
        assert got == expected, text
    assert whole.engine.state.record.rows() == bytewise.engine.state.record.rows()
    assert whole.engine.state.values == bytewise.engine.state.values
