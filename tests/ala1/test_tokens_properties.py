"""Property-based tests of the tokenizer (§4, spec notes §2) and of the engine on bad input."""

from __future__ import annotations

from datetime import datetime
from decimal import Decimal

from ala1_module import Module
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from sondalog.ala1.tokens import Cursor, NumberFormat, ParseError, format_stamp

NOW = datetime(2007, 6, 18, 11, 18, 6)
dates = st.datetimes(min_value=datetime(2000, 1, 1), max_value=datetime(2099, 12, 31))


@given(dates, st.sampled_from([0, 1, 2, 3, 4, 5]))
def test_date_with_fields_missing_on_the_left(moment: datetime, missing: int) -> None:
    moment = moment.replace(microsecond=0)
    stamp = format_stamp(moment)
    # drop whole fields from the left: year (4 digits), then 2-digit fields
    cut = 0 if missing == 0 else 4 + 2 * (missing - 1)
    written = stamp[cut:]
    filled = format_stamp(NOW)[:cut] + written
    try:
        expected = datetime.strptime(filled, "%Y%m%d%H%M%S")
    except ValueError:
        expected = None
    cur = Cursor(written)
    if expected is None:
        try:
            cur.date(NOW)
        except ParseError:
            return
        raise AssertionError(f"{written} accepted")
    assert cur.date(NOW) == expected
    assert cur.at_end()


@given(dates)
def test_date_fields_may_be_separated_by_spaces(moment: datetime) -> None:
    s = format_stamp(moment)
    spaced = " ".join([s[0:4], s[4:6], s[6:8], s[8:10], s[10:12], s[12:14]])
    assert Cursor(spaced).date(NOW) == moment.replace(microsecond=0)


@given(st.integers(0, 96), st.integers(0, 59), st.integers(0, 59), st.sampled_from([2, 4, 6]))
def test_period_missing_fields_on_the_right(hh: int, mm: int, ss: int, digits: int) -> None:
    full = f"{hh:02d}{mm:02d}{ss:02d}"
    written = full[:digits]
    canonical = written.ljust(6, "0")
    seconds = int(canonical[0:2]) * 3600 + int(canonical[2:4]) * 60 + int(canonical[4:6])
    cur = Cursor(written)
    if seconds > 96 * 3600:
        try:
            cur.period()
        except ParseError:
            return
        raise AssertionError(f"{written} accepted")
    assert cur.period() == canonical


@given(
    st.decimals(min_value=-99999, max_value=99999, allow_nan=False, places=4),
    st.integers(0, 9),
    st.integers(0, 9),
)
def test_number_format_rounds_half_away_from_zero(
    value: Decimal, width: int, decimals: int
) -> None:
    text = NumberFormat(width, decimals).render(value)
    assert len(text) >= width
    stripped = text.lstrip(" ")
    assert len(text) == width or stripped == text
    assert ("." in stripped) == (decimals > 0)
    if decimals:
        assert len(stripped.split(".")[1]) == decimals
    error = abs(Decimal(stripped) - value)
    assert error <= Decimal(1).scaleb(-decimals) / 2


def test_number_format_examples() -> None:
    assert NumberFormat(0, 1).render(Decimal("13.85")) == "13.9"
    assert NumberFormat(0, 1).render(Decimal("-13.85")) == "-13.9"
    assert NumberFormat(6, 2).render(Decimal("10.5")) == " 10.50"
    assert NumberFormat(0, 0).render(Decimal("2.5")) == "3"
    assert NumberFormat(0, 1).render(Decimal("-0.04")) == "0.0"


@given(st.lists(st.integers(1, 12), min_size=1, max_size=6), st.booleans())
def test_channel_lists_both_forms(channels: list[int], packed: bool) -> None:
    if packed:
        text = "".join(f"{c:02d}" for c in channels)
    else:
        text = " ".join(str(c) for c in channels)
    assert Cursor(text).channel_list() == channels


_BOUNDARY = st.characters(min_codepoint=33, max_codepoint=126)


@given(st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=30), _BOUNDARY)
def test_unknown_length_strings_with_any_boundary(value: str, boundary: str) -> None:
    assume(boundary not in value)
    cur = Cursor(f"{boundary}{value}{boundary}rest")
    assert cur.string() == value
    assert cur.rest() == "rest"
    assert Cursor(f"{boundary}{value}").string() == value  # closing boundary optional at end


@given(st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=20), _BOUNDARY)
def test_written_strings_read_back(value: str, boundary: str) -> None:
    assume(boundary not in value and not value.endswith(" "))
    m = Module()
    assert m.ask(f"write i name{boundary}{value}{boundary}") == b"OK\r\n"
    assert m.ask("read i name") == value.encode() + b"\r\nOK\r\n"


@given(st.sampled_from(["read", "write", "READ", "Write", "rEaD"]))
def test_keywords_any_case(switch: str) -> None:
    m = Module()
    answer = m.ask(f"{switch} I VERSION")
    assert answer in (b"2.10\r\nOK\r\n", f"{switch} I VERSION\r\nERROR\r\n".encode())
    assert (answer == b"2.10\r\nOK\r\n") == switch.lower().startswith("r")


@settings(max_examples=300)
@given(st.binary(max_size=300))
def test_random_bytes_never_break_the_engine(data: bytes) -> None:
    m = Module()
    out = m.feed(data)
    out += m.advance(61)
    # every answer is made of CR LF terminated lines, or echo fragments of what was sent
    assert m.ask("read i version").endswith(b"2.10\r\nOK\r\n")
    del out


_WORDS = st.sampled_from(
    [
        "read", "write", "channel", "1", "2", "12", "name", "/x/", "date", "i", "version",
        "record", "from", "start", "check", "sum", "crcsum", "quiet", "number", "counter",
        "global", "reset", "com", "speed", "9600", "file", "size", "-1", "0.5", "x", "all",
        "message", "of", "text", "nothing", "&", "pause", "99", "20070301090000",
    ]
)  # fmt: skip


@settings(max_examples=300)
@given(st.lists(_WORDS, max_size=14))
def test_half_commands_and_word_salad_get_protocol_answers(words: list[str]) -> None:
    m = Module()
    line = " ".join(words)
    answer = m.ask(line) + m.advance(100)
    if answer:
        valid = (
            answer.endswith(b"OK\r\n")
            or answer == line.encode()[:120] + b"\r\nERROR\r\n"
            or (answer.endswith(b"\r\n") and "quiet" in words)
        )
        assert valid, (line, answer)
    assert m.ask("read i version") == b"2.10\r\nOK\r\n"
