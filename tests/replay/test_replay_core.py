"""The pure parts of replay (issue 23): the line trace format and the matcher core."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sondalog.protocol.device import LineSend
from sondalog.protocol.line_trace import (
    Chunk,
    TraceError,
    escape,
    parse_trace,
    trace_line,
    unescape,
)
from sondalog.protocol.replay import ReplayDevice, exchanges


@given(st.binary(max_size=200))
def test_escape_round_trips_any_bytes(data: bytes) -> None:
    text = escape(data)
    assert "\n" not in text and "\r" not in text and not text.endswith(" ")
    assert unescape(text) == data


def test_trace_lines_read_back() -> None:
    lines = [
        "# sondalog line trace 1: tcp://127.0.0.1:10001\n",
        trace_line(True, b"read i version\r", 1_700_000_000.25),
        "\n",
        trace_line(False, b"2.10\r\nOK\r\n", 1_700_000_000.5),
    ]
    assert parse_trace(lines) == [
        Chunk(True, b"read i version\r", 1_700_000_000.25),
        Chunk(False, b"2.10\r\nOK\r\n", 1_700_000_000.5),
    ]


def test_the_gsm_modem_trace_is_read_too() -> None:
    """``sondalog serve --trace`` (gsm/trace.py) writes the modem's line this way."""
    text = [
        "2025-11-30T01:00:00.000Z  logger>modem  AT+CMGS=5\\r",
        "2025-11-30T01:00:00.100Z  modem>logger  \\r\\n> ",
        "2025-11-30T01:00:00.200Z  logger>modem  hello<ctrl-z>",
    ]
    chunks = parse_trace(text)
    assert [c.to_device for c in chunks] == [True, False, True]
    assert chunks[2].data == b"hello\x1a"


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("2025-11-30T01:00:00.000Z  host>bus  x", "trace:1: expected 'TIME  DIRECTION  BYTES'"),
        ("yesterday  host>logger  x", "trace:1: bad time stamp 'yesterday'"),
        ("2025-11-30T01:00:00.000Z  host>logger  a\\", "trace:1: a lone backslash at column 2"),
    ],
)
def test_a_bad_trace_line_is_named(line: str, message: str) -> None:
    with pytest.raises(TraceError) as caught:
        parse_trace(["# comment", "", line][2:])
    assert str(caught.value).startswith(message)


def _device(*chunks: tuple[bool, bytes], lenient: bool = False) -> ReplayDevice:
    return ReplayDevice([Chunk(to, data) for to, data in chunks], lenient=lenient)


def _say(device: ReplayDevice, line: int, data: bytes) -> bytes:
    out = device.receive(line, data, 0.0)
    assert all(isinstance(o, LineSend) and o.line == line for o in out)
    return b"".join(o.data for o in out if isinstance(o, LineSend))


SESSION = (
    (True, b"read i version\r"),
    (False, b"2.10\r\n"),
    (False, b"OK\r\n"),
    # a pipeline: three lines in one write, their answers in one read
    (True, b"read i snumber\rbogus\rread i version\r"),
    (False, b"000001\r\nOK\r\nbogus\r\nERROR\r\n2.11\r\nOK\r\n"),
)


def test_a_pipeline_answer_is_split_at_its_final_lines() -> None:
    prologue, found = exchanges(Chunk(to, data) for to, data in SESSION)
    assert prologue == b""
    assert [(e.sent, bytes(e.answer)) for e in found] == [
        (b"read i version", b"2.10\r\nOK\r\n"),
        (b"read i snumber", b"000001\r\nOK\r\n"),
        (b"bogus", b"bogus\r\nERROR\r\n"),
        (b"read i version", b"2.11\r\nOK\r\n"),
    ]


def test_strict_replay_answers_in_order_whatever_the_pipelining() -> None:
    device = _device(*SESSION)
    line = device.open_line()
    assert _say(device, line, b"read i ver") == b""  # half a line: nothing yet
    assert _say(device, line, b"sion\r\n") == b"2.10\r\nOK\r\n"  # CR LF is one line end
    assert _say(device, line, b"read i snumber\r") == b"000001\r\nOK\r\n"
    assert _say(device, line, b"bogus\rread i version\r") == b"bogus\r\nERROR\r\n2.11\r\nOK\r\n"
    device.close_line(line)
    assert device.deviations == [] and device.played == 4


def test_strict_replay_reports_a_deviation_to_the_host_and_waits() -> None:
    device = _device(*SESSION)
    line = device.open_line()
    _say(device, line, b"read i version\r")
    answer = _say(device, line, b"read i version\r")
    assert answer == b"read i version\r\nERROR\r\n"  # §3.3.1: the host sees an error
    assert _say(device, line, b"read i snumber\r") == b"000001\r\nOK\r\n"  # back on track
    device.close_line(line)  # two exchanges never sent: the first is reported
    assert [(d.kind, d.index, d.expected, d.got) for d in device.deviations] == [
        ("different", 1, "read i snumber", "read i version"),
        ("missing", 2, "bogus", None),
    ]
    assert [d.describe() for d in device.deviations] == [
        "line 1: exchange 2: expected 'read i snumber', got 'read i version'",
        "line 1: exchange 3 'bogus' and the 1 after it never sent",
    ]


def test_strict_replay_past_the_end_is_a_deviation() -> None:
    device = _device((True, b"a\r"), (False, b"OK\r\n"))
    line = device.open_line()
    assert _say(device, line, b"a\ra\r") == b"OK\r\na\r\nERROR\r\n"
    assert device.deviations[0].kind == "beyond"


def test_each_line_replays_from_the_start() -> None:
    device = _device(*SESSION)
    first, second = device.open_line(), device.open_line()
    assert _say(device, first, b"read i version\r") == b"2.10\r\nOK\r\n"
    assert _say(device, second, b"read i version\r") == b"2.10\r\nOK\r\n"


def test_lenient_replay_matches_by_text_in_any_order() -> None:
    device = _device(*SESSION, lenient=True)
    line = device.open_line()
    assert _say(device, line, b"read  i snumber \r") == b"000001\r\nOK\r\n"  # spaces normalised
    # recorded twice: the answers in the recorded order, then the last one again
    assert _say(device, line, b"read i version\r") == b"2.10\r\nOK\r\n"
    assert _say(device, line, b"read i version\r") == b"2.11\r\nOK\r\n"
    assert _say(device, line, b"read i version\r") == b"2.11\r\nOK\r\n"
    # unknown: the protocol's error response (§3.3.1), noted
    assert _say(device, line, b"read date\r") == b"read date\r\nERROR\r\n"
    device.close_line(line)
    assert [(d.kind, d.got) for d in device.deviations] == [("unknown", "read date")]


def test_raw_exchanges_without_line_ends() -> None:
    """XMODEM (tables pull, §6.16): the host's ``C`` and ``ACK`` have no line end."""
    block = b"\x01\x01\xfe" + b"\r" * 128 + b"\x00\x00"
    device = _device(
        (True, b"read file list xmodem\r"),
        (False, b"OK\r\n"),
        (True, b"C"),
        (False, block),
        (True, b"\x06"),
        (False, b"\x04"),
        (True, b"\x06"),
    )
    assert [e.raw for e in device.exchanges] == [False, True, True, True]
    line = device.open_line()
    assert _say(device, line, b"read file list xmodem\r") == b"OK\r\n"
    assert _say(device, line, b"C") == block
    assert _say(device, line, b"\x06") == b"\x04"
    assert _say(device, line, b"\x15") == b"\x15\r\nERROR\r\n"


def test_a_line_without_end_is_bounded() -> None:
    device = _device(*SESSION)
    line = device.open_line()
    answer = _say(device, line, b"x" * 5000)
    assert answer == b"x" * 60 + b"\r\nERROR\r\n"
    assert device.deviation_count == 1


def test_an_upload_block_with_line_ends_is_one_raw_exchange() -> None:
    """``write special file list xmodem`` then ``C`` in one burst, and a block carrying LF
    (a table's text): each is one exchange, answered once it is whole, never line by line."""
    block = b"\x01\x01\xfetabulka1 36\ntabulka2 59\n" + b"\x1a" * 104 + b"\x12\x0a"
    device = _device(
        (True, b"read special file list xmodem\r"),
        (True, b"C"),
        (False, b"\x04"),
        (True, b"write special file list xmodem\r"),
        (False, b"C"),
        (True, block),
        (False, b"\x06"),
    )
    assert [(e.raw, bytes(e.answer)) for e in device.exchanges] == [
        (True, b"\x04"),
        (False, b"C"),
        (True, b"\x06"),
    ]
    line = device.open_line()
    assert _say(device, line, b"read special file list xmodem\r") == b""
    assert _say(device, line, b"C") == b"\x04"
    assert _say(device, line, b"write special file list xmodem\r") == b"C"
    assert _say(device, line, block[:20]) == b""  # a part of the block: nothing yet
    assert _say(device, line, block[20:]) == b"\x06"
    assert device.deviations == []
