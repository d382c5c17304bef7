"""The XMODEM sender byte by byte: start, blocks, retries, EOT, cancel, 1K blocks."""

from __future__ import annotations

import pytest

from sondalog.protocol.xmodem import XmodemSender
from sondalog.protocol.xmodem.frames import ACK, CAN, EOT, NAK, SOH, STX, SUB, frame

ACK_ = bytes([ACK])
NAK_ = bytes([NAK])
EOT_ = bytes([EOT])
CANCAN = bytes([CAN, CAN])


def started(data: bytes, **kw: object) -> XmodemSender:
    s = XmodemSender(data, **kw)  # type: ignore[arg-type]
    assert s.start(0.0) == b""
    return s


def test_waits_for_the_receiver_and_ignores_noise() -> None:
    s = started(b"hello")
    assert s.next_deadline() == 60.0
    assert s.receive(b"\r\nxyz", 1.0) == b""
    assert s.crc is None
    out = s.receive(b"C", 2.0)
    assert s.crc is True
    assert out == frame(1, b"hello" + bytes([SUB]) * 123, crc=True)
    assert s.next_deadline() == 12.0


def test_nak_start_means_checksum_and_custom_pad() -> None:
    s = started(b"hi", pad=0x00)
    assert s.receive(NAK_, 0.0) == frame(1, b"hi" + bytes(126), crc=False)
    assert s.crc is False


def test_no_receiver_gives_up() -> None:
    s = started(b"x", start_timeout=5.0)
    assert s.advance(4.9) == b""
    assert s.advance(5.0) == CANCAN
    assert s.done and not s.ok and s.error == "no start character from the receiver"


def test_whole_exchange_and_progress() -> None:
    data = bytes(range(256)) + b"tail"
    s = started(data)
    b1 = s.receive(b"C", 0.0)
    assert b1[:3] == bytes([SOH, 1, 0xFE]) and s.acked == 0
    assert s.receive(ACK_, 0.1)[:3] == bytes([SOH, 2, 0xFD])
    assert s.acked == 128
    b3 = s.receive(ACK_, 0.2)
    assert b3[3:7] == b"tail" and b3[7:131] == bytes([SUB]) * 124
    assert s.receive(ACK_, 0.3) == EOT_
    assert s.acked == s.total == 260
    assert s.receive(NAK_, 0.4) == EOT_  # receiver confirms EOT
    assert s.receive(ACK_, 0.5) == b""
    assert s.done and s.ok and s.error is None and s.next_deadline() is None


def test_empty_data_sends_eot_only() -> None:
    s = started(b"")
    assert s.receive(b"C", 0.0) == EOT_
    assert s.receive(b"C", 0.1) == EOT_  # a receiver that did not take it as the end
    assert s.receive(ACK_, 0.2) == b"" and s.ok


def test_nak_and_timeout_retransmit_then_give_up() -> None:
    s = started(b"x" * 10, retries=3)
    first = s.receive(NAK_, 0.0)
    assert s.receive(NAK_, 1.0) == first
    assert s.advance(10.9) == b""
    assert s.advance(11.0) == first  # 10 s without an answer
    assert s.receive(NAK_, 12.0) == first
    assert s.receive(NAK_, 13.0) == CANCAN
    assert s.done and not s.ok and s.error == "too many retries (NAK)"


def test_repeated_c_only_repeats_the_first_block() -> None:
    s = started(b"y" * 300)
    first = s.receive(b"C", 0.0)
    assert s.receive(b"C", 0.1) == first
    s.receive(ACK_, 0.2)
    assert s.receive(b"C", 0.3) == b""  # later, C is noise


def test_one_reaction_per_read_the_last_answer_counts() -> None:
    s = started(b"z" * 1000)
    first = s.receive(b"C", 0.0)
    # Two ACKs in one read: the first was for a duplicate, both sent before block 2 existed.
    second = s.receive(ACK_ + ACK_, 0.1)
    assert second[1] == 2
    assert s.acked == 128
    # NAK then ACK: the retransmission that crossed the NAK arrived.
    assert s.receive(NAK_ + b"?" + ACK_ + b"!", 0.2)[1] == 3
    # ACK then NAK: the ACK was stale, block 3 goes again.
    third = s.receive(ACK_ + NAK_, 0.3)
    assert third[1] == 3 and s.acked == 256
    assert first[1] == 1


def test_can_can_from_receiver_aborts_even_in_a_stale_tail() -> None:
    s = started(b"q" * 1000)
    s.receive(b"C", 0.0)
    assert s.receive(bytes([CAN]), 0.1) == b""
    assert not s.done
    assert s.receive(ACK_ + bytes([CAN, CAN]), 0.2) == b""
    assert s.done and not s.ok and s.error is not None and "CAN CAN" in s.error


def test_local_cancel() -> None:
    s = started(b"q" * 1000)
    s.receive(b"C", 0.0)
    assert s.cancel() == CANCAN
    assert s.done and not s.ok and s.error == "cancelled locally"
    assert s.receive(ACK_, 0.1) == b"" and s.advance(100.0) == b""


@pytest.mark.parametrize(
    ("size", "starts"),
    [
        (1024, [STX]),
        (1025, [STX, SOH]),
        (1024 + 896, [STX] + [SOH] * 7),
        (1024 + 897, [STX, STX]),
        (3000, [STX, STX, STX]),
        (100, [SOH]),
    ],
)
def test_1k_blocks_with_a_128_byte_tail(size: int, starts: list[int]) -> None:
    s = started(bytes(size), one_k=True)
    seen = []
    out = s.receive(b"C", 0.0)
    while out != EOT_:
        seen.append(out[0])
        out = s.receive(ACK_, 0.0)
    assert seen == starts


def test_1k_is_not_used_with_the_checksum() -> None:
    s = started(bytes(2048), one_k=True)
    assert s.receive(NAK_, 0.0)[0] == SOH


def test_must_start_first() -> None:
    with pytest.raises(RuntimeError):
        XmodemSender(b"").advance(0.0)
