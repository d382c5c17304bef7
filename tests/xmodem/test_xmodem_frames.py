"""Block framing and check values of XMODEM (Christensen 1982, Forsberg 1988)."""

from __future__ import annotations

from sondalog.protocol.xmodem import checksum8, crc16
from sondalog.protocol.xmodem.frames import SOH, STX, frame, frame_length


def test_crc16_is_crc16_xmodem() -> None:
    # The catalogue check value of CRC-16/XMODEM (poly 0x1021, init 0).
    assert crc16(b"123456789") == 0x31C3
    assert crc16(b"") == 0


def test_checksum_is_sum_modulo_256() -> None:
    assert checksum8(bytes([0xFF, 0x02])) == 0x01
    assert checksum8(b"\x1a" * 128) == (0x1A * 128) & 0xFF


def test_frame_layout_crc_and_checksum() -> None:
    payload = bytes(range(128))
    block = frame(1, payload, crc=True)
    assert block[:3] == bytes([SOH, 1, 0xFE])
    assert block[3:131] == payload
    assert block[131:] == crc16(payload).to_bytes(2, "big")
    assert len(block) == frame_length(SOH, crc=True) == 133
    block = frame(2, payload, crc=False)
    assert block[131:] == bytes([checksum8(payload)])
    assert len(block) == frame_length(SOH, crc=False) == 132


def test_frame_1k_and_number_wrap() -> None:
    block = frame(256 + 3, b"\x00" * 1024, crc=True)
    assert block[:3] == bytes([STX, 3, 0xFC])
    assert len(block) == frame_length(STX, crc=True) == 1029
