"""XMODEM control bytes, block framing and check values.

What this implements: the block format of Ward Christensen's XMODEM (1977/1982) with the
extensions of Chuck Forsberg's "XMODEM/YMODEM protocol reference" (1988): the 16-bit CRC
(CCITT polynomial 0x1021, initial value 0, sent high byte first, requested by the receiver
with ``C``) and 1024-byte blocks (``STX`` instead of ``SOH``)::

    SOH|STX  blk  255-blk  data[128|1024]  checksum[1] | crc16[2]
"""

from __future__ import annotations

import binascii
from typing import Final

SOH: Final = 0x01
"""Start of a 128-byte block."""
STX: Final = 0x02
"""Start of a 1024-byte block (XMODEM-1K)."""
EOT: Final = 0x04
"""End of transmission (sender)."""
ACK: Final = 0x06
"""Block or EOT accepted (receiver)."""
NAK: Final = 0x15
"""Block refused, send it again; also the receiver's start character for checksum mode."""
CAN: Final = 0x18
"""Cancel; two in a row end the transfer."""
CRC_START: Final = 0x43
"""``C``: the receiver's start character asking for CRC-16 mode."""
SUB: Final = 0x1A
"""The conventional padding byte of the last block (CP/M end-of-file, ^Z)."""

CANCEL: Final = bytes([CAN, CAN])
"""What either side sends to abort a transfer."""

BLOCK_SIZES: Final = {SOH: 128, STX: 1024}
"""Payload size announced by each block start byte."""


def checksum8(data: bytes) -> int:
    """The original XMODEM check: arithmetic sum of the payload bytes, modulo 256."""
    return sum(data) & 0xFF


def crc16(data: bytes) -> int:
    """CRC-16/XMODEM (poly 0x1021, init 0, no reflection), as ``binascii.crc_hqx`` computes."""
    return binascii.crc_hqx(data, 0)


def check_bytes(payload: bytes, crc: bool) -> bytes:
    """The check value that follows a block's payload: 2 bytes of CRC or 1 byte of checksum."""
    if crc:
        return crc16(payload).to_bytes(2, "big")
    return bytes([checksum8(payload)])


def check_length(crc: bool) -> int:
    """Length of the check value in the given mode."""
    return 2 if crc else 1


def frame(number: int, payload: bytes, crc: bool) -> bytes:
    """One complete block: start byte, block number and its complement, payload, check.

    The start byte follows the payload length (128 → SOH, 1024 → STX); ``number`` is taken
    modulo 256, the wrap of XMODEM's block counter.
    """
    start = {128: SOH, 1024: STX}[len(payload)]
    blk = number & 0xFF
    return bytes([start, blk, 0xFF - blk]) + payload + check_bytes(payload, crc)


def frame_length(start: int, crc: bool) -> int:
    """Length of a whole block that begins with ``start`` (SOH or STX)."""
    return 3 + BLOCK_SIZES[start] + check_length(crc)
