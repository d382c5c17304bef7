"""XMODEM transfers with a logger over any client connection (§6.16).

The command goes out as a line; then the pure XMODEM peer (:mod:`sondalog.protocol.xmodem`) runs on
the same connection with the event loop's clock; then the logger's final answer (``OK`` or
the error response) is read.

Progress (``progress(done, total)``, total 0 when unknown) counts bytes the other side has
taken: blocks the logger acknowledged when sending, complete blocks received when receiving;
never bytes merely queued for the line.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ClientError
from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender

Progress = Callable[[int, int], None]
_ACK, _CAN = 0x06, 0x18


class TransferFailed(ClientError):
    """The XMODEM transfer did not complete, or the logger refused what it received."""


async def upload(
    client: Ala1Client, command: str, data: bytes, progress: Progress | None = None
) -> None:
    """Run ``command`` (``write special ... xmodem``) and send ``data`` by XMODEM."""
    sender = XmodemSender(data, one_k=True)
    leftover = await _run(client, command, sender, progress, lambda: (sender.acked, sender.total))
    await _final(client, command, leftover, sender.ok, sender.error)


async def download(
    client: Ala1Client,
    command: str,
    progress: Progress | None = None,
    max_size: int | None = None,
    expected: int | None = None,
) -> bytes:
    """Run ``command`` (``read special ... xmodem``) and receive the area by XMODEM; the
    result keeps the 0x1A padding (cut it with the lengths in the table list, §10.4).
    ``expected``: the size the caller knows the content has (the total for ``progress``)."""
    receiver = XmodemReceiver(max_size=max_size)

    def state() -> tuple[int, int]:
        if expected is None:
            return receiver.received, 0
        return min(receiver.received, expected), expected

    leftover = await _run(client, command, receiver, progress, state)
    await _final(client, command, leftover, receiver.ok, receiver.error)
    return receiver.data


async def _run(
    client: Ala1Client,
    command: str,
    peer: XmodemSender | XmodemReceiver,
    progress: Progress | None,
    state: Callable[[], tuple[int, int]],
) -> bytes:
    loop = asyncio.get_running_loop()
    await client.send_raw(command.encode("latin-1") + b"\r")
    first = peer.start(loop.time())
    if first:
        await client.send_raw(first)
    while not peer.done:
        deadline = peer.next_deadline()
        wait = 1.0 if deadline is None else min(1.0, max(0.0, deadline - loop.time()))
        data = await client.receive_raw(wait)
        now = loop.time()
        reply = peer.receive(data, now) if data else peer.advance(now)
        if reply:
            await client.send_raw(reply)
        if progress is not None:
            progress(*state())
        if peer.done and isinstance(peer, XmodemSender):
            # the logger's answer follows its last ACK (or CAN) in the same read
            return data[max(data.rfind(bytes([_ACK])), data.rfind(bytes([_CAN]))) + 1 :]
    return b""


async def _final(
    client: Ala1Client, command: str, leftover: bytes, ok: bool, error: str | None
) -> None:
    answer = leftover
    for _ in range(50):
        if answer.endswith(b"OK\r\n") or answer.endswith(b"ERROR\r\n"):
            break
        more = await client.receive_raw(client.timeout)
        if not more:
            break
        answer += more
    text = answer.lstrip(b"\x04\x06\x15\x18").decode("latin-1")
    if not ok:
        raise TransferFailed(f"{command}: XMODEM transfer failed: {error}")
    if not text.endswith("OK\r\n") or text.endswith("ERROR\r\n"):
        raise TransferFailed(f"{command}: the logger refused the transfer ({text.strip()!r})")
