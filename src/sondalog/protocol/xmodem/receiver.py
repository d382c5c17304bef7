"""The receiving end of an XMODEM transfer, sans-I/O.

What this implements (Christensen 1982, Forsberg 1988):

- Start: ``C`` (CRC-16) every ``start_interval`` (3 s); after ``crc_tries`` unanswered ``C``
  it falls back to ``NAK`` (8-bit checksum), the usual convention. Without ``crc`` it sends
  ``NAK`` from the start. Garbage before the first block is ignored. No sender within
  ``start_timeout`` (60 s): ``CAN CAN`` and failure.
- Blocks of 128 (``SOH``) and 1024 (``STX``) bytes are both accepted, mixed in one transfer.
- The first block settles the mode, whatever the start character was: the sender may have
  seen an earlier ``C`` than the ``NAK`` of the fallback, or ignore ``C``. A first block that
  fails as a checksum block is given one more byte to pass as a CRC block; a CRC-mode first
  block that stops one byte short (``byte_timeout``) is tried as a checksum block.
- A block with a bad complement or a bad checksum/CRC, a partial block (``byte_timeout``, 1 s
  between bytes), or garbage where a block should start: purge (wait until the line has been
  quiet for ``byte_timeout``), then ``NAK``. Nothing within ``block_timeout`` (10 s): ``NAK``.
  More than ``retries`` (10) errors in a row: ``CAN CAN`` and failure.
- The expected block is ACKed and kept; the previous one again (its ACK was lost) is ACKed and
  ignored; any other number means the ends are out of step: ``CAN CAN`` and failure.
- One ACK per request: a duplicate is ACKed only once after each ``NAK`` the receiver sent
  (other copies are ignored and do not restart the block timer). When the sender's timeout
  and the receiver's ``NAK`` cross, the sender transmits the block twice; ACKing both would
  make the sender take the second ACK for the next block and run one block ahead. A sender
  that retransmits on its own after a lost ACK is answered at the next ``NAK`` instead.
- ``EOT``: with ``confirm_eot`` (the default) the first ``EOT`` is NAKed and only a repeated
  ``EOT`` is ACKed, so that a noise byte cannot end the transfer early; ``sx``, ``rx`` and the
  ``xmodem`` package all send ``EOT`` again after a ``NAK``. Without it, ``EOT`` is ACKed at
  once. An ``EOT`` before any block is an empty transfer. After success, a repeated ``EOT``
  (our final ACK was lost) is ACKed again.
- ``max_size``: a block whose content (trailing padding not counted) would end beyond it, or
  which starts beyond it, cancels the transfer with ``CAN CAN``; nothing is kept.
- Two consecutive ``CAN`` where a block should start abort the transfer; ``CAN`` inside a
  block is data. After any failure :attr:`XmodemReceiver.data` is empty.
"""

from __future__ import annotations

from .frames import ACK, BLOCK_SIZES, CRC_START, EOT, NAK, SUB, check_bytes
from .frames import frame_length as _frame_length
from .transfer import Transfer


class XmodemReceiver(Transfer):
    """Receives one file from an XMODEM sender into :attr:`data` (padding included)."""

    def __init__(
        self,
        max_size: int | None = None,
        *,
        crc: bool = True,
        pad: int = SUB,
        block_timeout: float = 10.0,
        byte_timeout: float = 1.0,
        start_interval: float = 3.0,
        start_timeout: float = 60.0,
        crc_tries: int = 3,
        retries: int = 10,
        confirm_eot: bool = True,
    ) -> None:
        super().__init__()
        self._max_size = max_size
        self._crc = crc
        self._pad = pad
        self._block_timeout = block_timeout
        self._byte_timeout = byte_timeout
        self._start_interval = start_interval
        self._start_timeout = start_timeout
        self._crc_tries = crc_tries
        self._retries = retries
        self._confirm_eot = confirm_eot
        self._state = "start"
        self._start_time = 0.0
        self._starts_sent = 0
        self._buf = bytearray()
        self._need = 0
        self._expected = 1
        self._received_any = False
        self._data = bytearray()
        self._content_end = 0
        self._errors = 0
        self._wait_deadline: float | None = None
        """The deadline that was running when the current block began."""
        self._dup_ok = False
        """May a duplicate of the last block be ACKed? Once after each NAK we sent."""

    @property
    def crc(self) -> bool:
        """The mode in use: True for CRC-16, False for the 8-bit checksum."""
        return self._crc

    @property
    def data(self) -> bytes:
        """The payload received so far, padding of the last block included; empty on failure."""
        return bytes(self._data)

    @property
    def received(self) -> int:
        """Bytes received so far (for progress reports)."""
        return len(self._data)

    def start(self, now: float) -> bytes:
        """Begin the transfer: returns the first start character, ``C`` or ``NAK``."""
        self._started = True
        self._start_time = now
        return self._send_start(now)

    def receive(self, data: bytes, now: float) -> bytes:
        """Feed bytes read from the line; returns bytes to write to it."""
        self._check_started()
        if self._done:
            return bytes([ACK]) if self._ok and EOT in data else b""
        out = bytearray()
        i = 0
        while i < len(data) and not self._done:
            if self._state == "block":
                take = min(self._need - len(self._buf), len(data) - i)
                self._buf += data[i : i + take]
                i += take
                self._deadline = now + self._byte_timeout
                if len(self._buf) == self._need:
                    out += self._on_block(now)
            elif self._state == "purge":
                i = len(data)
                self._deadline = now + self._byte_timeout
            else:
                byte = data[i]
                i += 1
                out += self._on_control(byte, now)
        return bytes(out)

    def advance(self, now: float) -> bytes:
        """Handle an expired deadline: repeat the start character, NAK, or give up."""
        self._check_started()
        if self._done or self._deadline is None or now < self._deadline:
            return b""
        if self._state == "start":
            if now - self._start_time >= self._start_timeout:
                return self._give_up("no sender")
            return self._send_start(now)
        if self._state == "purge":
            return self._nak(now)
        if self._state == "block":
            if self._maybe_checksum_block():
                return self._on_block(now, extend=False)
            why = "timeout within a block"
        else:
            why = "timeout waiting for a block"
        return self._error_then_nak(why, now)

    def _send_start(self, now: float) -> bytes:
        self._starts_sent += 1
        if self._crc and self._starts_sent > self._crc_tries:
            self._crc = False
        self._deadline = now + self._start_interval
        return bytes([CRC_START if self._crc else NAK])

    def _on_control(self, byte: int, now: float) -> bytes:
        """A byte where a block, EOT or CAN may start."""
        if self._peer_cancelled(byte):
            return b""
        if byte in BLOCK_SIZES:
            self._state = "block"
            self._wait_deadline = self._deadline
            self._buf = bytearray([byte])
            self._need = _frame_length(byte, self._crc)
            self._deadline = now + self._byte_timeout
            return b""
        if byte == EOT:
            if self._state == "eot" or not self._confirm_eot:
                self._succeed()
                return bytes([ACK])
            self._state = "eot"
            self._dup_ok = True
            self._deadline = now + self._block_timeout
            return bytes([NAK])
        if self._state == "start" or self._last_was_can:
            return b""
        return self._bad("garbage where a block should start", now)

    def _on_block(self, now: float, extend: bool = True) -> bytes:
        """A whole block is in the buffer (its length tells the mode)."""
        buf = bytes(self._buf)
        size = BLOCK_SIZES[buf[0]]
        crc = len(buf) == size + 5
        number, complement = buf[1], buf[2]
        payload = buf[3 : 3 + size]
        if number + complement != 0xFF or buf[3 + size :] != check_bytes(payload, crc):
            if extend and not crc and not self._received_any:
                self._need += 1  # perhaps a CRC block: the sender saw an earlier C
                return b""
            return self._bad("bad block", now)
        self._crc = crc  # the first block settles the mode
        self._state = "wait"
        if number == self._expected:
            if self._exceeds(payload):
                return self._give_up(f"more data than max_size ({self._max_size} bytes)")
            self._data += payload
            self._expected = (self._expected + 1) & 0xFF
            self._received_any = True
            self._errors = 0
            self._dup_ok = False
            self._deadline = now + self._block_timeout
            return bytes([ACK])
        if self._received_any and number == (self._expected - 1) & 0xFF:
            if not self._dup_ok:
                self._deadline = self._wait_deadline
                return b""
            self._dup_ok = False
            self._deadline = now + self._block_timeout
            return bytes([ACK])
        return self._give_up(f"block {number} where {self._expected} was expected")

    def _maybe_checksum_block(self) -> bool:
        """First block, CRC expected, and a checksum block's worth arrived, then silence."""
        return (
            not self._received_any
            and self._crc
            and len(self._buf) == _frame_length(self._buf[0], crc=False)
        )

    def _exceeds(self, payload: bytes) -> bool:
        """Would this block take the content beyond ``max_size``?"""
        if self._max_size is None:
            return False
        offset = len(self._data)
        content = len(payload.rstrip(bytes([self._pad])))
        if content:
            self._content_end = offset + content
        return offset > self._max_size or self._content_end > self._max_size

    def _bad(self, why: str, now: float) -> bytes:
        """Count an error and purge the line before NAKing."""
        self._errors += 1
        if self._errors > self._retries:
            return self._give_up(f"too many errors ({why})")
        self._state = "purge"
        self._deadline = now + self._byte_timeout
        return b""

    def _error_then_nak(self, why: str, now: float) -> bytes:
        self._errors += 1
        if self._errors > self._retries:
            return self._give_up(f"too many errors ({why})")
        return self._nak(now)

    def _nak(self, now: float) -> bytes:
        if self._state != "start":
            self._state = "wait"
        self._dup_ok = True
        self._deadline = now + self._block_timeout
        return bytes([NAK])

    def _fail(self, error: str) -> None:
        super()._fail(error)
        self._data = bytearray()


__all__ = ["XmodemReceiver"]
