"""CRC-16/MODBUS, the frame check of the HCTMPS1 bus framing (hctmps1.md §2).

Polynomial 0x8005 reflected (0xA001), initial value 0xFFFF, no final XOR. The check value of
``b"123456789"`` is ``0x4B37``.
"""

from __future__ import annotations


def _make_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_TABLE = _make_table()


def crc16_modbus(data: bytes) -> int:
    """CRC-16/MODBUS of ``data`` (hctmps1.md §2)."""
    crc = 0xFFFF
    for byte in data:
        crc = (crc >> 8) ^ _TABLE[(crc ^ byte) & 0xFF]
    return crc
