"""Framing and CRC properties (hctmps1.md §2), checked with hypothesis."""

from __future__ import annotations

import pytest
from hctmps1_helpers import crc_bitwise
from hypothesis import given
from hypothesis import strategies as st

from sondalog.hctmps1 import Frame, FrameDecoder, FrameError, crc16_modbus, encode_frame

ids = st.text("ABCXYZabcxyz0189_-", min_size=1, max_size=8)
bodies = st.text(
    st.characters(min_codepoint=0x20, max_codepoint=0x7E, exclude_characters="|"), min_size=1
)
frames = st.builds(Frame, st.one_of(ids, st.just("*")), ids, bodies)


@given(st.binary())
def test_crc_matches_the_bitwise_reference(data: bytes) -> None:
    assert crc16_modbus(data) == crc_bitwise(data)


@given(st.lists(frames, max_size=5), st.lists(st.integers(0, 400), max_size=6))
def test_decoder_round_trip_in_any_chunking(items: list[Frame], cuts: list[int]) -> None:
    stream = b"".join(f.encode() for f in items)
    decoder = FrameDecoder()
    got: list[Frame] = []
    start = 0
    for cut in sorted(cuts):
        got += decoder.feed(stream[start:cut])
        start = max(start, cut)
    got += decoder.feed(stream[start:])
    assert got == items


@given(frames, st.binary(max_size=40).filter(lambda b: b":" not in b and b"\n" not in b))
def test_garbage_before_the_colon_is_skipped(item: Frame, garbage: bytes) -> None:
    assert FrameDecoder().feed(garbage + item.encode()) == [item]


@given(frames, st.data())
def test_any_single_byte_change_is_rejected_or_yields_no_different_frame(
    item: Frame, data: st.DataObject
) -> None:
    raw = bytearray(item.encode())
    index = data.draw(st.integers(0, len(raw) - 3))  # keep CR LF so the line ends
    new = data.draw(st.integers(0, 255).filter(lambda b: b != raw[index]))
    raw[index] = new
    decoded = FrameDecoder().feed(bytes(raw))
    # CRC-16 detects every single-byte error: nothing (or nothing else) comes out.
    assert decoded == [] or decoded == [item]


@given(frames, frames)
def test_a_good_frame_after_a_truncated_one_is_found(first: Frame, second: Frame) -> None:
    raw = first.encode()
    truncated = raw[: len(raw) // 2]
    assert FrameDecoder().feed(truncated + second.encode()) == [second]


@pytest.mark.parametrize(
    ("dst", "src", "body"),
    [("", "PC", "X"), ("T1", "*", "X"), ("T1", "PC", "A|B"), ("T1", "PC", ""), ("T1", "P C", "X")],
)
def test_encode_rejects_bad_fields(dst: str, src: str, body: str) -> None:
    with pytest.raises(FrameError):
        encode_frame(dst, src, body)
