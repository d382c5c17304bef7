"""A collector's contact in two chained lines (issue 24, :mod:`sondalog.client.visit`): what it
reads is what the step by step path reads, on random configurations of a real served logger,
of both protocol versions; an answer of another shape goes step by step.

The pure part (:func:`plan`, :func:`parse`) is held to the manual's answer shapes with made
answers: complete or not, refused, cut, a failed ``crcsum``.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from served_logger import Served, sampling_logger, serving
from test_contact_pipeline import CHANNEL, ROW, configure, stepwise

from sondalog.client import Ala1Client
from sondalog.client.ala1_codec import MAX_LINE, CrcMismatch
from sondalog.client.download import Download
from sondalog.client.visit import IDENT, Known, Unexpected, Visit, keep, parse, plan, visit
from sondalog.collect.readings import rows_to_readings
from sondalog.protocol.cksum import cksum


@pytest.fixture(scope="module")
def logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    with sampling_logger(tmp_path_factory.mktemp("visit"), 50) as served:
        served.ask("write date 20070301000000", "write channel sampling period 000000")
        yield served


@pytest.fixture(scope="module")
def old_logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    with serving(tmp_path_factory.mktemp("visit116"), "--protocol", "1.16") as served:
        served.ask("write date 20070301000000")
        yield served


async def visited(
    url: str, after: str | None, per: int, guess: int | None, last: Known | None = None
) -> tuple[Any, ...]:
    async with await Ala1Client.connect(url) as client:
        download = Download(client, after=after, rows_per_chunk=per, max_rows=per)
        got = await visit(download, guess, last)
        chunks = [chunk async for chunk in download.chunks()]
    return got, chunks


def _same(served: Served, after: str | None, per: int, guess: int | None) -> Visit:
    """Step by step and the visit read the same; the visit."""
    old_info, old_answers, old_chunks = asyncio.run(stepwise(served.url, after, per))
    got, new_chunks = asyncio.run(visited(served.url, after, per, guess))
    assert (got.info.snumber, got.info.channels) == (old_info.snumber, old_info.channels)
    assert got.status == (old_answers[0].lines[0] if old_answers[0].ok else None)
    assert got.kinds == (old_answers[1].lines if old_answers[1].ok else ())
    assert [(c.rows, c.gap) for c in new_chunks] == [(c.rows, c.gap) for c in old_chunks]
    readings = [rows_to_readings(c.rows, got.info.snumber, got.info.channels) for c in new_chunks]
    assert readings == [
        rows_to_readings(c.rows, old_info.snumber, old_info.channels) for c in old_chunks
    ]
    record = served.record()
    expected = [r for r in record if after is None or r.split(",")[0] > after]
    assert [row.key for c in new_chunks for row in c.rows] == [r.split(",")[0] for r in expected]
    return got


@settings(
    max_examples=15,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    channels=st.lists(CHANNEL, min_size=1, max_size=12),  # names in up to two lines
    rows=st.lists(ROW, max_size=25),
    cursor=st.none() | st.integers(0, 30),
    per=st.sampled_from([1, 2, 3, 7, 20]),
    guess=st.sampled_from(["right", "fewer", "more", "unknown"]),
)
def test_a_visit_reads_what_the_step_by_step_path_reads(
    logger: Served,
    channels: list[tuple[str, str | None, bool]],
    rows: list[tuple[str, int, Any]],
    cursor: int | None,
    per: int,
    guess: str,
) -> None:
    configure(logger, channels, rows)
    record = logger.record()
    after = None
    if cursor is not None and record:
        after = record[min(cursor, len(record) - 1)].split(",")[0]
    count = len(channels)
    last = {"right": count, "fewer": max(1, count - 3), "more": count + 2, "unknown": None}
    _same(logger, after, per, last[guess])


def test_the_identification_of_the_last_contact_is_taken_when_it_answers_the_same(
    logger: Served,
) -> None:
    """Same answers: the last visit's channels (not parsed again); a channel renamed since:
    read and parsed again, the new name in the readings."""
    configure(logger, [("A", "V", False), ("B", None, False)], [("value", 2, [1, 2])])
    first, _ = asyncio.run(visited(logger.url, None, 20, 2))
    again, _ = asyncio.run(visited(logger.url, None, 20, 2, keep(first)))
    assert again.key == first.key and again.info.channels is first.info.channels
    logger.ask("write channel 2 name/Level[m]/")
    renamed, chunks = asyncio.run(visited(logger.url, None, 20, 2, keep(again)))
    assert renamed.key != first.key
    assert renamed.info.channels[2].name == "Level" and renamed.info.channels[2].unit == "m"
    readings = rows_to_readings(chunks[0].rows, renamed.info.snumber, renamed.info.channels)
    assert {(r.channel, r.name, r.unit) for r in readings} == {(1, "A", "V"), (2, "Level", "m")}


@pytest.mark.parametrize("guess", [None, 1, 3, 8, 9])
def test_a_1_16_logger_is_visited_alike(old_logger: Served, guess: int | None) -> None:
    """Protocol 1.16 answers the same lines; 9 names are more than a 1.16 logger has (8
    channels: the line of ``read channel 9 name`` refused): the contact goes step by step
    and reads the same."""
    old_logger.ask(
        "write record status clear",
        "write channel max number 3 write output 1 value 1",
        "write channel 1 type 1 write channel 2 type 1 write channel 3 type 1",
        "write channel 2 name/T[C]/",
        "write channel value",
        "write channel 1 3 value 2",
    )
    got = _same(old_logger, None, 20, guess)
    assert (got.key is None) == (guess == 9)


# -- the pure part: lines and answers --------------------------------------------------------


def test_the_lines_fit_what_a_module_keeps_and_hold_every_command() -> None:
    after = "20070301120000.3"
    for names in range(100):
        for chunk in (
            "read record 5000 from start",
            f"read record 1 from start read record 5000 from date/{after}/",
        ):
            lines = plan(names, chunk)
            assert lines is not None
            assert all(len(line) <= MAX_LINE for line in lines.lines)
            assert lines.lines[0].startswith(IDENT)
            assert sum(lines.answers) == 5 + names
            assert " ".join(lines.lines[:-1]).count(" name") == names
            assert lines.lines[-1].startswith("crcsum read record status ")
            assert lines.payload == ("\r".join(lines.lines) + "\r").encode()
    assert plan(2, f"read record 1 from start read record 20 from date/{'9' * 80}/") is None


def _answer(*parts: list[str], crc: bool = True) -> bytes:
    """The bytes of answers: each part its data lines (then ``OK``), the last one with its
    ``crcsum`` line; a part ``["ERROR", line]`` is the error response to ``line``."""
    out = b""
    for index, part in enumerate(parts):
        if part[:1] == ["ERROR"]:
            out += f"{part[1]}\r\nERROR\r\n".encode()
            continue
        body = "".join(f"{line}\r\n" for line in part).encode()
        if index == len(parts) - 1 and crc:
            body += f"{cksum(body)},{len(body)}\r\n".encode()
        out += body + b"OK\r\n"
    return out


IDENTIFIED = ["F00001", "20070301120000", "2", "1,1", "0.1,0.1", "Supply[V]", "T[C]"]
ROWS = ["20070301115900.0,1,12.0,3.5", "20070301120000.0,1,12.0,3.6"]


def test_an_answer_is_read_whole_once_complete() -> None:
    lines = plan(2, "read record 1 from start read record 20 from date/20070301115900.0/")
    assert lines is not None
    raw = _answer(IDENTIFIED, ["160,0.00,FILLING", *ROWS])
    for cut in range(len(raw)):
        assert parse(lines, raw[:cut]) is None
    got = parse(lines, raw)
    assert got is not None
    assert got.ident == tuple(IDENTIFIED) and got.status == "160,0.00,FILLING"
    assert got.rows == tuple(ROWS)
    chunk = "".join(f"{r}\r\n" for r in ROWS).encode()
    whole = b"160,0.00,FILLING\r\n" + chunk
    assert got.chunk == chunk + f"{cksum(whole)},{len(whole)}\r\nOK\r\n".encode()
    assert got.crc == (cksum(whole), len(whole))


def test_an_answer_of_another_shape_is_unexpected_once_every_line_is_answered() -> None:
    lines = plan(2, "read record 20 from start")
    assert lines is not None
    record = ["160,0.00,FILLING", *ROWS]
    shapes = [
        _answer(["ERROR", lines.lines[0]], record),  # the identification refused
        _answer(IDENTIFIED, ["ERROR", lines.lines[1]]),  # the record line refused
        _answer(IDENTIFIED[:-1], record),  # a name missing
        _answer([*IDENTIFIED, "x"], record),  # a line too many
        _answer(IDENTIFIED, ["160,0.00,FILLING"], crc=False),  # no crcsum line
    ]
    for raw in shapes:
        with pytest.raises(Unexpected):
            parse(lines, raw)
    # a refused first line, the second not answered yet: wait for it
    assert parse(lines, _answer(["ERROR", lines.lines[0]])) is None
    broken = _answer(IDENTIFIED, record).replace(b"3.6", b"3.7")
    with pytest.raises(CrcMismatch):
        parse(lines, broken)


@given(st.text("0123456789.-,x ", max_size=24))
def test_a_row_of_numbers_is_told_as_field_by_field(body: str) -> None:
    """parse_row's one match for the whole row: each field a number (§4.3.4) or empty."""
    import re

    from sondalog.client.records import parse_row

    number = re.compile(r"-?\d+(\.\d+)?")
    numbers = all(not f or number.fullmatch(f) for f in body.split(","))
    row = parse_row(f"20070301120000.0,1,{body}")
    assert (row.text is None) == numbers
    if numbers:
        assert row.values == tuple(float(f) if f else None for f in body.split(","))


def cksum_reference(data: bytes) -> int:
    """POSIX ``cksum`` by its definition, bit by bit: the data, then its length's bytes."""
    crc = 0
    tail = []
    length = len(data)
    while length:
        tail.append(length & 0xFF)
        length >>= 8
    for byte in bytes(data) + bytes(tail):
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) if crc & 0x80000000 else crc << 1
            crc &= 0xFFFFFFFF
    return ~crc & 0xFFFFFFFF


@given(st.binary(max_size=300))
def test_cksum_in_c_is_posix_cksum(data: bytes) -> None:
    assert cksum(data) == cksum_reference(data)


def test_cksum_of_long_data() -> None:
    for size in (0, 255, 256, 65535, 65536, 70_000):
        data = os.urandom(size)
        assert cksum(data) == cksum_reference(data)
