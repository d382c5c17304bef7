"""What the XMODEM sender and receiver share: the final state, the deadline and CAN CAN.

Both ends are sans-I/O state machines in the manner of h11 (DESIGN.md point 1): the caller
feeds the bytes it read and the current time, writes back what the machine returns, and calls
:meth:`Transfer.advance` once :meth:`Transfer.next_deadline` has passed.
"""

from __future__ import annotations

from .frames import CAN, CANCEL


class Transfer:
    """Final state, one pending deadline, and detection of the peer's ``CAN CAN``."""

    def __init__(self) -> None:
        self._started = False
        self._done = False
        self._ok = False
        self._error: str | None = None
        self._deadline: float | None = None
        self._last_was_can = False

    @property
    def done(self) -> bool:
        """True once the transfer has ended, successfully or not."""
        return self._done

    @property
    def ok(self) -> bool:
        """True if the transfer ended successfully."""
        return self._ok

    @property
    def error(self) -> str | None:
        """Why the transfer failed, or None."""
        return self._error

    def next_deadline(self) -> float | None:
        """When :meth:`advance` must be called next; None when nothing is pending."""
        return None if self._done else self._deadline

    def cancel(self) -> bytes:
        """Abort the transfer locally; returns ``CAN CAN`` to send (nothing if already over)."""
        if self._done:
            return b""
        self._fail("cancelled locally")
        return CANCEL

    def _check_started(self) -> None:
        if not self._started:
            raise RuntimeError("call start() first")

    def _peer_cancelled(self, byte: int) -> bool:
        """Track consecutive CANs outside blocks; True (and failed) on the second one."""
        if byte == CAN:
            if self._last_was_can:
                self._fail("cancelled by the peer (CAN CAN)")
                return True
            self._last_was_can = True
        else:
            self._last_was_can = False
        return False

    def _fail(self, error: str) -> None:
        self._done = True
        self._ok = False
        self._error = error
        self._deadline = None

    def _succeed(self) -> None:
        self._done = True
        self._ok = True
        self._error = None
        self._deadline = None

    def _give_up(self, error: str) -> bytes:
        """Fail and tell the peer: the ``CAN CAN`` to send."""
        self._fail(error)
        return CANCEL
