"""The XMODEM receiver byte by byte: start, blocks, errors, EOT, cancel, max_size."""

from __future__ import annotations

import pytest

from sondalog.protocol.xmodem import XmodemReceiver
from sondalog.protocol.xmodem.frames import ACK, CAN, EOT, NAK, SUB, frame

C = b"C"
ACK_ = bytes([ACK])
NAK_ = bytes([NAK])
EOT_ = bytes([EOT])
CANCAN = bytes([CAN, CAN])


def block(n: int, fill: int = 0x41, crc: bool = True, size: int = 128) -> bytes:
    return frame(n, bytes([fill]) * size, crc)


def started(**kw: object) -> XmodemReceiver:
    r = XmodemReceiver(**kw)  # type: ignore[arg-type]
    r.start(0.0)
    return r


def test_start_sends_c_then_falls_back_to_nak() -> None:
    r = XmodemReceiver()
    assert r.start(0.0) == C
    assert r.next_deadline() == 3.0
    assert r.advance(2.9) == b""
    assert r.advance(3.0) == C
    assert r.advance(6.0) == C
    assert r.advance(9.0) == NAK_
    assert r.crc is False
    # A checksum block is now expected (132 bytes).
    assert r.receive(block(1, crc=False), 9.5) == ACK_


def test_checksum_receiver_starts_with_nak() -> None:
    r = XmodemReceiver(crc=False)
    assert r.start(0.0) == NAK_


def test_no_sender_gives_up_with_can() -> None:
    r = started(start_timeout=10.0)
    out = b""
    now = 0.0
    while not r.done:
        now = r.next_deadline() or now
        out += r.advance(now)
    assert out.endswith(CANCAN)
    assert r.done and not r.ok and r.error == "no sender"
    assert r.next_deadline() is None


def test_garbage_before_first_block_is_ignored() -> None:
    r = started()
    assert r.receive(b"\r\n", 0.1) == b""
    assert r.receive(block(1), 0.2) == ACK_


def test_blocks_eot_confirmed() -> None:
    r = started()
    assert r.receive(block(1) + b"", 0.1) == ACK_
    assert r.receive(block(2, 0x42), 0.2) == ACK_
    assert r.receive(EOT_, 0.3) == NAK_
    assert not r.done
    assert r.receive(EOT_, 0.4) == ACK_
    assert r.done and r.ok and r.error is None
    assert r.data == b"A" * 128 + b"B" * 128
    # Our last ACK was lost: the sender repeats EOT, we ACK again.
    assert r.receive(EOT_, 10.4) == ACK_


def test_eot_acked_at_once_without_confirmation() -> None:
    r = started(confirm_eot=False)
    r.receive(block(1), 0.1)
    assert r.receive(EOT_, 0.2) == ACK_
    assert r.ok


def test_block_after_nakked_eot_continues() -> None:
    r = started()
    r.receive(block(1), 0.1)
    assert r.receive(EOT_, 0.2) == NAK_  # noise that looked like EOT
    assert r.receive(block(2), 0.3) == ACK_
    assert len(r.data) == 256


def test_empty_transfer() -> None:
    r = started()
    assert r.receive(EOT_, 0.1) == NAK_
    assert r.receive(EOT_, 0.2) == ACK_
    assert r.ok and r.data == b""


def test_mixed_128_and_1k_blocks() -> None:
    r = started()
    assert r.receive(block(1, size=1024), 0.1) == ACK_
    assert r.receive(block(2, size=128), 0.2) == ACK_
    assert len(r.data) == 1152


def test_bad_crc_purges_then_naks() -> None:
    r = started()
    bad = bytearray(block(1))
    bad[50] ^= 0x01
    assert r.receive(bytes(bad) + b"trailing junk", 0.1) == b""
    # More junk keeps the line busy: still no NAK.
    assert r.receive(b"x", 0.9) == b""
    assert r.advance(1.5) == b""
    assert r.next_deadline() == pytest.approx(1.9)
    assert r.advance(1.9) == NAK_
    assert r.receive(block(1), 2.0) == ACK_


def test_bad_complement_is_a_bad_block() -> None:
    r = started()
    bad = bytearray(block(1))
    bad[2] = 0x00
    assert r.receive(bytes(bad), 0.1) == b""
    assert r.advance(1.1) == NAK_


def test_partial_block_times_out_and_naks() -> None:
    r = started()
    assert r.receive(block(1)[:60], 0.1) == b""
    assert r.next_deadline() == pytest.approx(1.1)
    assert r.advance(1.1) == NAK_
    assert r.receive(block(1), 1.2) == ACK_


def test_split_at_every_byte() -> None:
    r = started()
    out = b"".join(r.receive(bytes([b]), 0.1) for b in block(1) + block(2))
    assert out == ACK_ + ACK_


def test_silence_naks_every_block_timeout_then_gives_up() -> None:
    r = started(retries=3)
    r.receive(block(1), 0.0)
    outs = []
    while not r.done:
        deadline = r.next_deadline()
        assert deadline is not None
        outs.append(r.advance(deadline))
    assert outs == [NAK_, NAK_, NAK_, CANCAN]
    assert r.error is not None and "too many errors" in r.error
    assert r.data == b""


def test_duplicate_after_nak_is_acked_once_and_ignored() -> None:
    r = started()
    assert r.receive(block(1), 0.0) == ACK_  # suppose this ACK is lost
    assert r.advance(10.0) == NAK_
    # The sender repeats block 1 (for the NAK and, crossing it, for its own timeout).
    assert r.receive(block(1), 10.1) == ACK_
    assert r.receive(block(1), 10.2) == b""
    assert r.receive(block(2), 10.3) == ACK_
    assert len(r.data) == 256


def test_duplicate_without_nak_waits_for_the_timeout() -> None:
    r = started()
    assert r.receive(block(1) + block(1), 0.0) == ACK_
    assert r.next_deadline() == 10.0
    assert r.advance(10.0) == NAK_
    assert r.receive(block(1), 10.1) == ACK_


def test_wrong_block_number_cancels() -> None:
    r = started()
    r.receive(block(1), 0.0)
    assert r.receive(block(3), 0.1) == CANCAN
    assert r.done and not r.ok and r.data == b""
    assert r.error == "block 3 where 2 was expected"


def test_block_numbers_wrap_at_255() -> None:
    r = started()
    for n in range(1, 300):
        assert r.receive(block(n, fill=n & 0xFF), float(n)) == ACK_
    assert r.receive(EOT_ + EOT_, 400.0) == NAK_ + ACK_
    assert r.ok and len(r.data) == 299 * 128
    assert r.data[255 * 128] == 0  # block 256 travelled as number 0


def test_can_can_from_sender_aborts() -> None:
    r = started()
    r.receive(block(1), 0.0)
    assert r.receive(bytes([CAN]), 0.1) == b""
    assert not r.done
    assert r.receive(bytes([CAN]), 0.2) == b""
    assert r.done and not r.ok and r.data == b""
    assert r.error is not None and "CAN CAN" in r.error


def test_single_can_is_ignored_and_can_is_data_inside_blocks() -> None:
    r = started()
    assert r.receive(bytes([CAN]) + block(1, fill=CAN), 0.0) == ACK_
    assert r.receive(block(2, fill=CAN), 0.1) == ACK_
    assert r.data == bytes([CAN]) * 256 and not r.done


def test_local_cancel() -> None:
    r = started()
    r.receive(block(1), 0.0)
    assert r.cancel() == CANCAN
    assert r.done and not r.ok and r.data == b"" and r.error == "cancelled locally"
    assert r.cancel() == b""


@pytest.mark.parametrize("size", [1, 100, 128])
def test_max_size_counts_content_not_padding(size: int) -> None:
    r = started(max_size=size)
    payload = b"z" * size + bytes([SUB]) * (128 - size)
    assert r.receive(frame(1, payload, True), 0.0) == ACK_
    assert r.receive(EOT_ + EOT_, 0.1) == NAK_ + ACK_
    assert r.ok and r.data == payload


def test_max_size_exceeded_cancels_and_keeps_nothing() -> None:
    r = started(max_size=200)
    assert r.receive(block(1), 0.0) == ACK_
    assert r.receive(block(2), 0.1) == CANCAN
    assert r.done and not r.ok and r.data == b""
    assert r.error == "more data than max_size (200 bytes)"


def test_max_size_refuses_extra_padding_blocks_beyond_the_limit() -> None:
    r = started(max_size=128)
    pad = bytes([SUB]) * 128
    assert r.receive(block(1), 0.0) == ACK_
    assert r.receive(frame(2, pad, True), 0.1) == ACK_  # starts at the limit: allowed
    assert r.receive(frame(3, pad, True), 0.2) == CANCAN


def test_must_start_first() -> None:
    with pytest.raises(RuntimeError):
        XmodemReceiver().receive(b"x", 0.0)


def test_first_block_in_crc_mode_after_fallback_to_nak() -> None:
    r = started(crc_tries=1)
    assert r.advance(3.0) == NAK_  # fallback sent; the sender had already seen the C
    assert r.receive(block(1, crc=True), 3.1) == ACK_
    assert r.crc is True
    assert r.receive(block(2, crc=True), 3.2) == ACK_


def test_first_block_in_checksum_mode_although_c_was_sent() -> None:
    r = started()
    assert r.receive(block(1, crc=False), 0.1) == b""  # waits for a 133rd byte
    assert r.advance(1.1) == ACK_
    assert r.crc is False
    assert r.receive(block(2, crc=False), 1.2) == ACK_
    assert len(r.data) == 256
