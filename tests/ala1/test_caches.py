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


# -- parsed lines (Plan) and compiled on-demand measurements ---------------------------------


def test_a_parsed_read_follows_the_channel_count() -> None:
    m = one_channel(volts=1.5)
    assert m.read("read channel value") == "1.50"
    assert m.read("read channel value") == "1.50"  # the second time from the parsed line
    m.ok("write channel 2 switch output 0 write channel 3 switch output 0")
    m.ok("write channel max number 3")
    # channels 2 and 3 are factory type 1: the supply, none simulated here: no value
    assert m.read("read channel value") == "1.50,,"
    m.ok("write channel max number 1")
    assert m.read("read channel value") == "1.50"


def test_a_parsed_read_yields_to_a_new_command_name() -> None:
    m = one_channel()
    assert m.read("read i version") == "2.10"
    m.ok("write command 1 value*read text/named/* write command 1 name/read i/")
    # §6.8.2: the longest command name that prefixes the line runs instead
    assert m.read("read i version") == "named"
    m.ok("write command 1 name//")
    assert m.read("read i version") == "2.10"


def test_a_parsed_read_obeys_the_own_address() -> None:
    m = one_channel()
    assert m.ask("iaddress abc read i version") == b"2.10\r\nOK\r\n"  # no own address yet
    m.ok("write i address xyz")
    assert m.ask("iaddress abc read i version") == b""  # another module's line (§8.5.3)


def test_a_parsed_pause_line_waits_every_time() -> None:
    m = one_channel()
    for _ in range(2):
        assert m.ask("pause 2 read i version") == b""
        assert m.advance(1.0) == b""
        assert m.advance(1.0) == b"2.10\r\nOK\r\n"


def test_the_parsed_lines_kept_are_bounded() -> None:
    m = one_channel()
    for n in range(600):
        assert m.read(f"read text/{n}/") == str(n)
    assert 0 < len(m.engine.state.plans) <= 256


def test_a_manual_output_change_makes_a_channel_wait_again() -> None:
    m = one_channel()
    m.ok("write channel 1 switch output 2 write channel 1 switch advance 1")
    m.ok("write output 2 device 1 write output 2 address 8 write output 2 value 1")
    assert m.read("read channel 1 value") == "1.00"  # held on by hand: no wait (§6.7.2)
    m.ok("write output 2 value NO")
    assert m.ask("read channel 1 value") == b""  # the module switches it: the advance first
    assert m.settle("") == b"1.00\r\nOK\r\n"


@given(seconds=st.lists(st.floats(0.0, 90000.0), min_size=1, max_size=5))
def test_on_demand_reads_match_the_long_way(seconds: list[float]) -> None:
    """Every kind of channel, read at the same instants with the compiled measurements
    (``Measurer.fast``) and through the interpreted configuration: the same answers."""
    answers: list[list[bytes]] = []
    for fast in (True, False):
        m = mixed_module(fast)
        answers.append([])
        for step in seconds:
            m.advance(step)
            for line in ("read channel value", "read channel 1 2 3 4 7 value"):
                answers[-1].append(m.settle(line))
            answers[-1].extend(m.ask(f"read channel {ch} value") for ch in (1, 2, 3, 4, 6, 7))
    assert answers[0] == answers[1]
    assert all(a.endswith(b"OK\r\n") for a in answers[0])


def mixed_module(fast: bool) -> Module:
    from sondalog.backends.sim.logger import PulseSource
    from sondalog.backends.sim.signals import sine

    hardware = SimHardware(
        supply=sine(12.4, 0.3, 86400.0, 0.0, 0.0),
        analog=[Analog(16, sine(1.1, 0.9, 3600.0, 0.0, 0.0)), Analog(17, constant(0.4))],
        pulses=[PulseSource(True, 0, rate=0.5, origin=0.0)],
    )
    hardware.external_reference = 2.0
    m = Module(hardware=hardware)
    m.engine.state.measurer.fast = fast
    m.ok("write channel max number 7 write output 2 device 1 write output 2 address 8")
    for ch, address in ((1, 16), (2, 17), (3, 32), (4, 33), (5, 16)):
        m.ok(f"write channel {ch} type 3 write channel {ch} address {address}")
        m.ok(f"write channel {ch} switch output 0 write channel {ch} format 1.{ch % 4}")
    m.ok("write channel 2 cal mult value 3.5 write channel 2 cal add value -0.25")
    m.ok("write channel 3 cal2 mult 1000 write channel 3 cal2 add 7")
    m.ok("write channel 5 switch output 2 write channel 5 switch advance 1")  # switched
    m.ok("write channel 6 type 2 write channel 6 device 1 write channel 6 address 0")  # pulses
    m.ok("write channel 7 switch output 0 write channel 7 cal mult value 2")  # the supply
    return m


def test_a_kept_answer_follows_the_committed_value() -> None:
    m = one_channel()
    assert m.read("read i name") == ""
    assert m.read("read i name") == ""  # kept: only a committed change can change it
    m.ok("write i name/north/")
    assert m.read("read i name") == "north"
    assert m.ask("sum read i name") == m.ask("sum read i name")
    assert m.ask("number 7 read i name read i version") == b"7,north\r\n8,2.10\r\n9,OK\r\n"
    assert m.ask("number 7 read i name read i version") == b"7,north\r\n8,2.10\r\n9,OK\r\n"


def test_answers_with_the_time_or_a_counter_are_made_every_time() -> None:
    m = one_channel()
    assert m.ask("counter 1 read i version") == b"0,2.10\r\n1,OK\r\n"
    assert m.ask("counter 1 read i version") == b"2,2.10\r\n3,OK\r\n"
    first = m.ask("date read i version")
    date = m.read("read date")
    m.advance(1.0)
    assert m.ask("date read i version") != first
    assert m.read("read date") != date


def test_a_failing_input_empties_only_its_channel_in_a_group_read() -> None:
    def broken(t: float) -> float:
        raise ZeroDivisionError("a broken signal model")

    hardware = SimHardware(analog=[Analog(16, constant(1.0)), Analog(17, broken)])
    m = Module(hardware=hardware)
    m.ok("write channel max number 3")
    for ch, address in ((1, 16), (2, 17), (3, 16)):
        m.ok(f"write channel {ch} type 3 write channel {ch} address {address}")
        m.ok(f"write channel {ch} switch output 0")
    assert m.read("read channel value") == "1.0,,1.0"
    hardware.set_signal("analog:17", 0.5)
    assert m.read("read channel value") == "1.0,0.5,1.0"
