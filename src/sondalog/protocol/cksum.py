"""POSIX ``cksum`` (§8.4.1 ``crcsum``): CRC-32 with polynomial 0x04C11DB7, MSB first,
over the data followed by its length, complemented."""

from __future__ import annotations

import zlib

#: Each byte value with its bits in the opposite order (bytes.translate).
_REVERSED = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))


def cksum(data: bytes) -> int:
    """The CRC that POSIX ``cksum`` prints for ``data``, through :func:`zlib.crc32` in C:
    the same polynomial, least significant bit first, so the bytes go in and the CRC comes
    out with their bits reversed, and ``crc32``'s start value 0xFFFFFFFF is cksum's register
    0 (ten times faster than byte by byte in Python; the tests hold it to the bitwise
    definition)."""
    length = len(data)
    tail = bytearray()
    while length:
        tail.append(length & 0xFF)
        length >>= 8
    crc = zlib.crc32(bytes(data).translate(_REVERSED), 0xFFFFFFFF)
    crc = zlib.crc32(bytes(tail).translate(_REVERSED), crc)
    return int.from_bytes(crc.to_bytes(4, "little").translate(_REVERSED), "big")
