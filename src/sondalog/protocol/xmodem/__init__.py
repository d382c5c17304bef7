"""XMODEM file transfer (checksum, CRC-16, 1K blocks), pure and sans-I/O.

Used by the ALA1 core for ``read|write special ... xmodem`` (§6.16) and by the host tools
(``tables push``/``pull``, §10.4). Each end is a state machine that takes the bytes read from
the line and the current time, and returns the bytes to write; it never reads a clock or
sleeps (DESIGN.md point 1). See docs/xmodem.md.
"""

from __future__ import annotations

from .frames import CANCEL, SUB, checksum8, crc16
from .receiver import XmodemReceiver
from .sender import XmodemSender

__all__ = ["CANCEL", "SUB", "XmodemReceiver", "XmodemSender", "checksum8", "crc16"]
