"""Interoperability with the ``xmodem`` package from PyPI (blocking; run in a thread over a
socketpair), both directions: checksum, CRC-16 and 1K blocks.

The package logs "send error: expected ACK; got b'\\x15'" when our receiver NAKs its first EOT
(we confirm EOT); it then sends EOT again, as expected.
"""

from __future__ import annotations

import io
import random

import pytest
from xmodem_pump import PackagePeer, pump

from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender
from sondalog.protocol.xmodem.frames import SOH, STX, SUB

SIZES = [1, 128, 1024, 1000, 100_003]
MODES = ["checksum", "crc", "1k"]


def payload(size: int) -> bytes:
    return random.Random(-size).randbytes(size)


def assert_padded(received: bytes, data: bytes, block: int) -> None:
    assert received[: len(data)] == data
    tail = received[len(data) :]
    assert tail == bytes([SUB]) * len(tail)
    assert len(tail) < block


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("mode", MODES)
def test_xmodem_our_sender_to_the_package(mode: str, size: int) -> None:
    data = payload(size)
    peer = PackagePeer("xmodem1k" if mode == "1k" else "xmodem")
    out = io.BytesIO()
    crc_mode = 0 if mode == "checksum" else 1
    peer.run(lambda modem: modem.recv(out, crc_mode=crc_mode, timeout=5, quiet=True))
    sender = XmodemSender(data, one_k=mode == "1k")
    writes: list[bytes] = []
    try:
        pump(sender, peer.ours.fileno(), peer.ours.fileno(), writes=writes)
        received = peer.join()
    finally:
        peer.close()
    assert sender.ok, sender.error
    assert sender.crc is bool(crc_mode)
    assert received == len(out.getvalue())
    assert_padded(out.getvalue(), data, 128)
    starts = {w[0] for w in writes if w[0] in (SOH, STX)}
    assert (STX in starts) is (mode == "1k" and size > 7 * 128)


@pytest.mark.parametrize("size", SIZES)
@pytest.mark.parametrize("mode", MODES)
def test_xmodem_package_sender_to_our_receiver(mode: str, size: int) -> None:
    data = payload(size)
    peer = PackagePeer("xmodem1k" if mode == "1k" else "xmodem")
    peer.run(lambda modem: modem.send(io.BytesIO(data), timeout=5, quiet=True))
    receiver = XmodemReceiver(crc=mode != "checksum")
    try:
        pump(receiver, peer.ours.fileno(), peer.ours.fileno())
        sent = peer.join()
    finally:
        peer.close()
    assert receiver.ok, receiver.error
    assert sent is True
    assert receiver.crc is (mode != "checksum")
    # The package pads its 1K blocks to 1024 bytes (1K with the 8-bit checksum, too).
    assert_padded(receiver.data, data, 1024 if mode == "1k" else 128)


def test_xmodem_package_sender_without_eot_confirmation() -> None:
    data = payload(5000)
    peer = PackagePeer()
    peer.run(lambda modem: modem.send(io.BytesIO(data), timeout=5, quiet=True))
    receiver = XmodemReceiver(confirm_eot=False)
    try:
        pump(receiver, peer.ours.fileno(), peer.ours.fileno())
        assert peer.join() is True
    finally:
        peer.close()
    assert receiver.ok
    assert_padded(receiver.data, data, 128)


def test_xmodem_package_receiver_cancelled_by_our_sender() -> None:
    peer = PackagePeer()
    out = io.BytesIO()
    peer.run(lambda modem: modem.recv(out, timeout=5, quiet=True))
    sender = XmodemSender(payload(50_000))
    try:
        fd = peer.ours.fileno()
        pump(_CancelAfter(sender, blocks=5), fd, fd)
        result = peer.join()
    finally:
        peer.close()
    assert result is None  # the package reports a cancelled transfer as None
    assert not sender.ok and sender.error == "cancelled locally"


class _CancelAfter:
    """Cancels the wrapped sender once it has had ``blocks`` blocks acknowledged."""

    def __init__(self, sender: XmodemSender, blocks: int) -> None:
        self.sender = sender
        self.blocks = blocks

    @property
    def done(self) -> bool:
        return self.sender.done

    def start(self, now: float) -> bytes:
        return self.sender.start(now)

    def receive(self, data: bytes, now: float) -> bytes:
        out = self.sender.receive(data, now)
        if self.sender.acked >= self.blocks * 128:
            return self.sender.cancel()
        return out

    def advance(self, now: float) -> bytes:
        return self.sender.advance(now)

    def next_deadline(self) -> float | None:
        return self.sender.next_deadline()
