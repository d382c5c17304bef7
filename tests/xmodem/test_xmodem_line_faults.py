"""Sender and receiver fed by each other over a damaged in-memory line, on a stepped clock.

Damage: flipped bytes, lost blocks, cut blocks, blocks delivered twice, blocks trickling in
pieces, lost or garbled ACK/NAK. The transfer must still succeed with the data intact.
Damage that XMODEM cannot survive by design is not injected: a NAK turned into an ACK, or
noise that looks like CAN CAN. XMODEM_EXAMPLES=N runs more hypothesis examples.
"""

from __future__ import annotations

import os

from hypothesis import given, settings
from hypothesis import strategies as st
from xmodem_line import Fault, Wire, run

from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender
from sondalog.protocol.xmodem.frames import ACK, CAN, CRC_START, NAK, SUB

PAD = bytes([SUB])


def assert_delivered(data: bytes, s: XmodemSender, r: XmodemReceiver) -> None:
    assert s.ok, s.error
    assert r.ok, r.error
    assert r.data[: len(data)] == data
    tail = r.data[len(data) :]
    assert tail == PAD * len(tail)
    assert len(tail) < 128


def sender_faults() -> st.SearchStrategy[dict[int, Fault]]:
    fault = st.builds(
        Fault,
        index=st.integers(0, 60),
        kind=st.sampled_from(["drop", "flip", "truncate", "duplicate", "split"]),
        pos=st.integers(0, 1100),
        mask=st.integers(1, 255),
        pieces=st.lists(st.integers(0, 1100), min_size=1, max_size=6).map(tuple),
    )
    return st.lists(fault, max_size=8).map(lambda fs: {f.index: f for f in fs})


def receiver_faults() -> st.SearchStrategy[dict[int, Fault]]:
    harmless = st.integers(0, 255).filter(lambda b: b not in (ACK, NAK, CAN, CRC_START))
    fault = st.builds(
        Fault,
        index=st.integers(0, 60),
        kind=st.sampled_from(["drop", "garble"]),
        mask=harmless,
    )
    return st.lists(fault, max_size=8).map(lambda fs: {f.index: f for f in fs})


@settings(max_examples=int(os.environ.get("XMODEM_EXAMPLES", "150")), deadline=None)
@given(
    data=st.one_of(
        st.binary(max_size=3000),
        st.sampled_from([1, 127, 128, 129, 1024, 1025, 2000]).map(lambda n: bytes(range(256)) * 9),
    ),
    one_k=st.booleans(),
    crc=st.booleans(),
    s2r=sender_faults(),
    r2s=receiver_faults(),
    latency=st.tuples(st.floats(0, 0.3), st.floats(0, 0.3)),
)
def test_xmodem_survives_a_damaged_line(
    data: bytes,
    one_k: bool,
    crc: bool,
    s2r: dict[int, Fault],
    r2s: dict[int, Fault],
    latency: tuple[float, float],
) -> None:
    s = XmodemSender(data, one_k=one_k)
    r = XmodemReceiver(crc=crc)
    run(s, r, Wire(latency[0], s2r), Wire(latency[1], r2s))
    assert_delivered(data, s, r)


def test_xmodem_corruption_and_lost_blocks_over_a_wrapping_transfer() -> None:
    data = bytes(i * 7 & 0xFF for i in range(300 * 128 + 5))  # block numbers wrap past 255
    s2r = {
        3: Fault(3, "flip", pos=40, mask=0x10),
        4: Fault(4, "drop"),
        5: Fault(5, "drop"),
        100: Fault(100, "truncate", pos=70),
        200: Fault(200, "duplicate"),
        256: Fault(256, "flip", pos=0, mask=0x05),  # SOH turned into EOT
        257: Fault(257, "split", pieces=(1, 2, 3, 64)),
        300: Fault(300, "flip", pos=1, mask=0xFF),  # block number
    }
    r2s = {10: Fault(10, "drop"), 11: Fault(11, "garble", mask=0x00), 150: Fault(150, "drop")}
    s = XmodemSender(data)
    r = XmodemReceiver()
    outcome = run(s, r, Wire(0.05, s2r), Wire(0.05, r2s))
    assert_delivered(data, s, r)
    assert outcome.now < 120.0


def test_xmodem_lost_final_ack_is_answered_again() -> None:
    s = XmodemSender(b"abc")
    r = XmodemReceiver()
    # Receiver writes: C, ACK (block), NAK (first EOT), ACK (second EOT) -> lose the last.
    run(s, r, Wire(0.01), Wire(0.01, {3: Fault(3, "drop")}))
    assert s.ok and r.ok


def test_xmodem_timeouts_crossing_give_one_ack_per_block() -> None:
    # Equal 10 s timeouts on both ends, no latency: after a lost ACK the receiver's NAK and
    # the sender's own retransmission happen at the same instant.
    data = bytes(range(256)) * 4
    s = XmodemSender(data, ack_timeout=10.0)
    r = XmodemReceiver(block_timeout=10.0)
    run(s, r, Wire(0.0), Wire(0.0, {1: Fault(1, "drop"), 4: Fault(4, "drop")}))
    assert_delivered(data, s, r)


def test_xmodem_checksum_fallback_with_a_late_sender() -> None:
    # The first three C are lost: the receiver falls back to NAK and checksum mode.
    data = b"late" * 100
    s = XmodemSender(data)
    r = XmodemReceiver()
    r2s = {i: Fault(i, "drop") for i in range(3)}
    run(s, r, Wire(0.01), Wire(0.01, r2s))
    assert_delivered(data, s, r)
    assert s.crc is False and r.crc is False


@settings(max_examples=60, deadline=None)
@given(
    who=st.sampled_from(["sender", "receiver"]),
    at=st.floats(0.001, 0.15),
    one_k=st.booleans(),
)
def test_xmodem_cancel_midway_fails_both_ends(who: str, at: float, one_k: bool) -> None:
    s = XmodemSender(bytes(range(256)) * 40, one_k=one_k)
    r = XmodemReceiver()
    run(s, r, Wire(0.01), Wire(0.01), cancel_at=(who, at))
    assert s.done and r.done
    assert not s.ok and not r.ok
    assert r.data == b""
    assert s.error is not None and r.error is not None
    local, remote = (s, r) if who == "sender" else (r, s)
    assert local.error == "cancelled locally"
    assert remote.error is not None and "CAN CAN" in remote.error


def test_xmodem_max_size_exceeded_fails_both_ends() -> None:
    s = XmodemSender(b"x" * 1000)
    r = XmodemReceiver(max_size=999)
    run(s, r, Wire(0.01), Wire(0.01))
    assert not r.ok and r.data == b"" and r.error is not None and "max_size" in r.error
    assert not s.ok and s.error is not None and "CAN CAN" in s.error
