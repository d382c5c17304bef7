"""Line discipline (§3.4, spec notes §1): terminators, echo, backspace, ESC, timeout, length."""

from __future__ import annotations

from ala1_module import Module


def test_cr_lf_crlf_lfcr_each_end_one_command(module: Module) -> None:
    one = b"2.10\r\nOK\r\n"
    assert module.feed(b"read i version\r") == one
    assert module.feed(b"read i version\n") == one
    assert module.feed(b"read i version\r\n") == one
    assert module.feed(b"read i version\n\r") == one
    assert module.feed(b"read i version\r\nread i version\r\n") == one * 2


def test_empty_lines_get_no_answer(module: Module) -> None:
    assert module.feed(b"\r\r\n\n   \r") == b""


def test_command_split_across_packets(module: Module) -> None:
    assert module.feed(b"read i ") == b""
    assert module.feed(b"vers") == b""
    assert module.feed(b"ion\r") == b"2.10\r\nOK\r\n"


def test_echo_sends_back_every_character(module: Module) -> None:
    assert module.feed(b"+read i version\r") == b"+read i version\r\n2.10\r\nOK\r\n"
    # echo is for that one command only
    assert module.feed(b"read i version\r") == b"2.10\r\nOK\r\n"


def test_backspace_and_delete_erase(module: Module) -> None:
    assert module.feed(b"+read i versiom\x08n\r") == b"+read i versiom\x08 \x08n\r\n2.10\r\nOK\r\n"
    assert module.feed(b"read i versiox\x7fn\r") == b"2.10\r\nOK\r\n"  # silent without echo
    assert module.feed(b"\x08\x08read i version\r") == b"2.10\r\nOK\r\n"  # nothing to erase


def test_escape_discards_partial_command(module: Module) -> None:
    assert module.feed(b"+read i\x1b") == b"+read i\r\nBREAK\r\n"
    assert module.feed(b"garbage\x1bread i version\r") == b"2.10\r\nOK\r\n"
    assert module.feed(b"\x1b") == b""  # no echo, nothing pending: silent


def test_entry_timeout_after_60_seconds(module: Module) -> None:
    assert module.feed(b"+read i") == b"+read i"
    assert module.engine.next_deadline() == module.now + 60
    assert module.advance(59.9) == b""
    assert module.advance(0.1) == b"\r\nBREAK\r\n"
    assert module.engine.next_deadline() is None
    assert module.feed(b" version\r") == b" version\r\nERROR\r\n"  # the start was discarded


def test_timeout_without_echo_is_silent(module: Module) -> None:
    module.feed(b"read i")
    assert module.advance(61) == b""
    assert module.feed(b"read i version\r") == b"2.10\r\nOK\r\n"


def test_timeout_counts_from_first_character(module: Module) -> None:
    module.feed(b"read")
    module.now += 50
    module.feed(b" i")
    module.now += 10
    assert module.feed(b" version\r") == b" version\r\nERROR\r\n"


def test_over_long_line_is_an_error_with_first_120_characters(module: Module) -> None:
    line = "read text/" + "x" * 130 + "/"
    assert module.ask(line) == line[:120].encode() + b"\r\nERROR\r\n"


def test_exactly_120_characters_is_accepted(module: Module) -> None:
    line = "read text/" + "y" * 109 + "/"
    assert len(line) == 120
    assert module.ask(line) == b"y" * 109 + b"\r\nOK\r\n"


def test_flow_control_characters_are_not_command_text(module: Module) -> None:
    assert module.feed(b"read\x13 i\x11 version\r") == b"2.10\r\nOK\r\n"


def test_binary_garbage_gets_the_error_response(module: Module) -> None:
    assert module.feed(b"\xff\xfe\x00read\r") == b"\xff\xfe\x00read\r\nERROR\r\n"


def test_lines_are_independent() -> None:
    m = Module()
    other = m.engine.open_line()
    assert m.feed(b"+read i ") == b"+read i "
    out = m.engine.receive(other, b"read date\r", m.now)
    assert [o.line for o in out] == [other]
    assert out[0].data == b"20000101000000\r\nOK\r\n"
    assert m.feed(b"version\r") == b"version\r\n2.10\r\nOK\r\n"
