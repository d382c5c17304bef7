"""The engine's caches (issue 11) never change what the protocol answers.

The typed channel configuration, ``com speed``/``i address``, the sampler's next event and the
keyword index are computed once per change: a committed write, a global reset, a table push,
a line's own staged write, or a measurement that starts a hold must each show at once.
"""

from __future__ import annotations

from ala1_module import Module
from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.tokens import Cursor
from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import constant
from sondalog.protocol.tables import build_files


def one_channel(volts: float = 1.0) -> Module:
    m = Module(hardware=SimHardware(analog=[Analog(16, constant(volts))]))
    m.ok("write channel max number 1")
    m.ok("write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0")
    m.ok("write channel 1 format 0.2")
    return m


def test_a_committed_write_changes_the_next_read() -> None:
    m = one_channel()
    assert m.read("read channel 1 value") == "1.00"  # the configuration is now cached
    m.ok("write channel 1 cal mult value 10")
    assert m.read("read channel 1 value") == "10.00"
    m.ok("write channel 1 cal add value 0.5")
    assert m.read("read channel 1 value") == "10.50"
    m.ok("write channel 1 format 3.0")
    assert m.read("read channel 1 value") == " 11"


def test_a_write_staged_on_the_same_line_is_seen_by_its_read() -> None:
    m = one_channel()
    assert m.read("read channel 1 value") == "1.00"
    answer = m.ask("write channel 1 cal mult value 3 read channel 1 value")
    assert answer == b"3.00\r\nOK\r\n"
    # a refused line commits nothing: the cached configuration still holds
    m.error("write channel 1 cal mult value 7 read channel 1 value read xyz")
    assert m.read("read channel 1 value") == "3.00"


def test_a_global_reset_brings_the_factory_configuration_back() -> None:
    m = one_channel()
    m.ok("write channel 1 cal mult value 10")
    assert m.read("read channel 1 value") == "10.00"
    m.ok("write global reset")
    # factory: channel 1 is type 1 (the supply, §6.5.3) with no supply simulated here
    assert m.read("read channel 1 type") == "1"
    assert m.read("read channel 1 format") == "0.1"
    m.ok("write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0")
    assert m.read("read channel 1 value") == "1.0"


def test_a_table_push_changes_the_next_read() -> None:
    m = one_channel(volts=1.0)
    m.ok("write file record size 983040 write file list size 256 write file data size 51200")
    m.ok("write channel 1 cal2 mult 1000")
    assert m.read("read channel 1 value") == "1000.00"
    m.ok("write channel 1 convert file name/lin/")
    assert m.read("read channel 1 value") == ""  # the table is missing: no value
    listing, data = build_files({"lin": b"0 0\n2000 4000\n"})
    m.engine.state.write_file("list", listing)
    m.engine.state.write_file("data", data)
    assert m.read("read channel 1 value") == "2000.00"
    listing, data = build_files({"lin": b"0 0\n2000 1000\n"})
    m.engine.state.write_file("data", data)
    assert m.read("read channel 1 value") == "500.00"


def test_com_speed_and_own_address_follow_their_writes() -> None:
    m = one_channel()
    assert m.read("read com speed") == "9600"
    m.ok("write com speed 19200")
    assert m.read("read com speed") == "19200"
    assert m.engine.line_speed() == 19200
    m.ok("write i address abc")
    assert m.ask("read i version") == b""  # another module's line: silence (§8.5.3)
    assert m.ask("iaddress abc read i version") == b"2.10\r\nOK\r\n"


def test_a_hold_started_by_a_read_moves_the_next_deadline() -> None:
    m = one_channel()
    m.ok("write channel 1 switch output 2 write channel 1 switch advance 1")
    m.ok("write output 2 device 1 write output 2 address 8")
    assert m.engine.next_deadline() is None  # nothing sampled, nothing held
    assert m.settle("read channel 1 value") == b"1.00\r\nOK\r\n"
    held = m.engine.next_deadline()
    assert held is not None and held > m.now  # the switch is held on (§6.9)
    m.advance(held - m.now)
    assert m.engine.next_deadline() is None


_WORDS = ("channel", "chan", "check", "crcsum", "c", "read", "write", "x", "value", "values")


@given(
    text=st.text(alphabet=st.sampled_from(list("chanelCHANEL rvwxİKsu")), max_size=14),
    start=st.integers(0, 3),
)
def test_choose_word_matches_choose_keyword(text: str, start: int) -> None:
    start = min(start, len(text))
    fast, slow = Cursor(text, start), Cursor(text, start)
    found = fast.choose_word(_WORDS)
    expected = slow.choose_keyword([(w,) for w in _WORDS])
    assert found == (None if expected is None else expected[0])
    assert fast.pos == slow.pos
