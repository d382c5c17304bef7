"""The far end's hang-up in the modem's data stream (``SHUTDOWN`` after a socket,
``NO CARRIER`` after a call) is found however the reads cut it: the logger's command
sessions and its mail connections share :class:`EndMarker`."""

from __future__ import annotations

import itertools

from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.modem.session import NO_CARRIER, SHUTDOWN, EndMarker

payload = st.binary(max_size=40).filter(lambda b: b"\r\n" not in b)


@given(
    before=payload,
    marker=st.sampled_from([SHUTDOWN, NO_CARRIER]),
    cuts=st.lists(st.integers(0, 80), max_size=4),
)
def test_the_marker_is_found_across_any_cut(before: bytes, marker: bytes, cuts: list[int]) -> None:
    stream = before + marker + b"after"
    points = sorted({0, len(stream), *(min(c, len(stream)) for c in cuts)})
    end = EndMarker(marker)
    passed = b""
    for start, stop in itertools.pairwise(points):
        data, ended = end.cut(stream[start:stop])
        passed += data
        if ended:
            break
    else:
        raise AssertionError("the marker was not found")
    # what went on before the marker: the bytes before it, and at most the marker's start
    # that came in an earlier read than its end
    assert passed.startswith(before)
    assert marker.startswith(passed[len(before) :])
    assert len(passed) - len(before) < len(marker)


def test_a_marker_cut_in_two_ends_the_mail_connection_too() -> None:
    end = EndMarker(SHUTDOWN)
    assert end.cut(b"250 OK\r\n\r\nSHUT") == (b"250 OK\r\n\r\nSHUT", False)
    assert end.cut(b"DOWN\r\n") == (b"", True)
