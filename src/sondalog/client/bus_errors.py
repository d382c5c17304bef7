"""What the bus master raises (hctmps1.md §2, §4)."""

from __future__ import annotations


class BusError(Exception):
    """Base of the bus master's errors."""


class NoReply(BusError):
    """No valid reply came within the timeout, after every retry."""


class UnexpectedReply(BusError):
    """A reply came but is not one the command can give."""


class ForeignPeer(BusError):
    """The peer answers with bytes that are not HCTMPS1 frames (an ALA1 logger, a modem)."""

    def __init__(self, message: str, heard: bytes) -> None:
        super().__init__(message)
        self.heard = heard
