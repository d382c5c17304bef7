"""The sending end of an XMODEM transfer, sans-I/O.

What this implements (Christensen 1982, Forsberg 1988):

- The receiver chooses the mode: ``C`` asks for CRC-16, ``NAK`` for the 8-bit checksum. Other
  bytes before that are line noise and ignored; the sender waits ``start_timeout`` (60 s).
- Blocks are numbered from 1, modulo 256. Each one waits for ``ACK``; ``NAK`` (or, for the
  first block, a repeated ``C``) or ``ack_timeout`` without an answer sends it again, at most
  ``retries`` times, then the sender gives up with ``CAN CAN``.
- With ``one_k`` and CRC mode the sender uses 1024-byte blocks (``STX``) and switches to
  128-byte blocks (``SOH``) for a tail of 896 bytes or less, so padding stays under 128 bytes.
  1K blocks are never used with the 8-bit checksum (Forsberg's advice: too weak a check).
- The last block is padded with ``pad`` (0x1A). After the data comes ``EOT``, repeated on
  ``NAK`` or timeout until ``ACK``. An empty ``data`` sends ``EOT`` straight away.
- Two consecutive ``CAN`` from the receiver (outside a block) abort the transfer.
- One reaction per read: of the answers in one chunk of input, only the last counts (``CAN
  CAN`` anywhere still aborts). Everything in a chunk was sent before the receiver could see
  our reaction to it, so earlier answers are superseded: ``NAK ACK`` means the retransmission
  that crossed the NAK arrived; ``ACK NAK`` means that ACK was stale.
"""

from __future__ import annotations

from .frames import ACK, CRC_START, EOT, NAK, SUB, frame
from .transfer import Transfer

_TAIL_128 = 7 * 128
"""A tail this short goes in 128-byte blocks even in 1K mode."""


class XmodemSender(Transfer):
    """Sends ``data`` to an XMODEM receiver."""

    def __init__(
        self,
        data: bytes,
        *,
        one_k: bool = False,
        pad: int = SUB,
        start_timeout: float = 60.0,
        ack_timeout: float = 10.0,
        retries: int = 10,
    ) -> None:
        super().__init__()
        self._data = bytes(data)
        self._one_k = one_k
        self._pad = pad
        self._start_timeout = start_timeout
        self._ack_timeout = ack_timeout
        self._retries = retries
        self._crc: bool | None = None
        self._state = "start"
        self._offset = 0
        """Start of the block in flight within ``data``."""
        self._length = 0
        """Payload bytes of ``data`` in the block in flight."""
        self._number = 1
        self._frame = b""
        self._errors = 0

    @property
    def crc(self) -> bool | None:
        """True in CRC-16 mode, False in checksum mode, None before the receiver has chosen."""
        return self._crc

    @property
    def total(self) -> int:
        """Length of the data to send."""
        return len(self._data)

    @property
    def acked(self) -> int:
        """Bytes of data the receiver has acknowledged so far (for progress reports)."""
        return self._offset

    def start(self, now: float) -> bytes:
        """Begin waiting for the receiver's ``C`` or ``NAK``; the sender sends nothing first."""
        self._started = True
        self._deadline = now + self._start_timeout
        return b""

    def receive(self, data: bytes, now: float) -> bytes:
        """Feed bytes read from the line; returns bytes to write to it."""
        self._check_started()
        last: int | None = None
        for byte in data:
            if self._done or self._peer_cancelled(byte):
                return b""
            if self._is_answer(byte):
                last = byte
        return b"" if last is None else self._on_answer(last, now)

    def advance(self, now: float) -> bytes:
        """Handle an expired deadline: retransmit, or give up."""
        self._check_started()
        if self._done or self._deadline is None or now < self._deadline:
            return b""
        if self._state == "start":
            return self._give_up("no start character from the receiver")
        return self._retry("timeout waiting for ACK", now)

    def _is_answer(self, byte: int) -> bool:
        """Is ``byte`` meaningful now? Anything else is line noise."""
        if self._state == "start":
            return byte in (CRC_START, NAK)
        return byte in (ACK, NAK) or (byte == CRC_START and self._offset == 0)

    def _on_answer(self, byte: int, now: float) -> bytes:
        if self._state == "start":
            self._crc = byte == CRC_START
            return self._send_next(now)
        if byte == ACK:
            if self._state == "eot":
                self._succeed()
                return b""
            self._offset += self._length
            self._number += 1
            self._errors = 0
            return self._send_next(now)
        return self._retry("NAK", now)  # NAK, or C repeated for the first block

    def _send_next(self, now: float) -> bytes:
        remaining = len(self._data) - self._offset
        if remaining <= 0:
            self._state = "eot"
            self._frame = bytes([EOT])
            self._length = 0
        else:
            self._state = "block"
            size = 1024 if self._one_k and self._crc and remaining > _TAIL_128 else 128
            chunk = self._data[self._offset : self._offset + size]
            self._length = len(chunk)
            payload = chunk.ljust(size, bytes([self._pad]))
            self._frame = frame(self._number, payload, bool(self._crc))
        self._deadline = now + self._ack_timeout
        return self._frame

    def _retry(self, why: str, now: float) -> bytes:
        self._errors += 1
        if self._errors > self._retries:
            return self._give_up(f"too many retries ({why})")
        self._deadline = now + self._ack_timeout
        return self._frame


__all__ = ["XmodemSender"]
