"""Several lines received at once (issue 24: a client's chained reads come as many lines in
one write) answer exactly as the same bytes received one by one, through the line
discipline's loop (§3.4: terminators, ``+`` echo, BS/DEL, ESC, 120 characters)."""

from __future__ import annotations

import itertools

from ala1_module import Module
from hypothesis import given, settings
from hypothesis import strategies as st

PIECES = st.sampled_from(
    [
        b"read i version",
        b"read i snumber",
        b"read channel 1 name",
        b"write channel 1 name T1",
        b"write channel 2 name/a b",
        b"read channel 2 name",
        b"read i nonsense",
        b"+read i version",
        b"+",
        b"read i versiom\x08n",
        b"read i vers\x7fsion",
        b"garbage\x1b",
        b"\x1b",
        b" ",
        b"r" * 125,
        b"read i version" + b" " * 106,  # 120 characters: the longest line (§3.4.1)
        b"read i version" + b" " * 107,  # 121: refused
        b"read channel 1 name read channel 2 name",
        b"\r",
        b"\n",
        b"\r\n",
        b"\n\r",
    ]
)


@settings(max_examples=300, deadline=None)
@given(
    pieces=st.lists(st.tuples(PIECES, st.sampled_from([b"\r", b"\r\n", b"\n", b""])), max_size=12),
    cuts=st.lists(st.integers(0, 2000), max_size=4),
)
def test_lines_at_once_answer_as_byte_by_byte(
    pieces: list[tuple[bytes, bytes]], cuts: list[int]
) -> None:
    """At once, and in chunks cut anywhere (TCP's segments), as byte by byte."""
    data = b"".join(text + end for text, end in pieces)
    ends = sorted({0, len(data), *(c % (len(data) + 1) for c in cuts)})
    at_once, chunked, by_byte = Module(), Module(), Module()
    try:
        want = b"".join(by_byte.feed(bytes([b])) for b in data)
        assert at_once.feed(data) == want
        assert b"".join(chunked.feed(data[a:b]) for a, b in itertools.pairwise(ends)) == want
        # and the state after: the same partial line, the same settings
        tail = b"\rread channel 1 name\rread channel 2 name\r"
        assert at_once.feed(tail) == chunked.feed(tail) == by_byte.feed(tail)
    finally:
        for module in (at_once, chunked, by_byte):
            module.store.close()
