"""An XMODEM transfer on a line of the ALA1 engine (§6.16): while it runs, the line's bytes
go to the XMODEM peer, not to the command parser; its end answers ``OK`` or the command's
error response, and an upload is applied (:func:`sondalog.ala1.special.apply`)."""

from __future__ import annotations

import logging
from typing import Protocol

from sondalog.ala1 import special
from sondalog.ala1.interpreter import Interpreter
from sondalog.ala1.lines import Line, Transfer
from sondalog.ala1.model import CommandError
from sondalog.ala1.state import ModuleState
from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender

log = logging.getLogger(__name__)

EOT = 0x04
#: After a completed upload, repeated EOTs (the host lost our last ACK) are still answered.
TRANSFER_GRACE = 2.0


class TransferEngine(Protocol):
    """What a transfer needs of its engine (:class:`sondalog.ala1.engine.Engine`, which
    passes itself): line time, the module, its error answers, and sending on a line."""

    @property
    def scale(self) -> float: ...
    @property
    def state(self) -> ModuleState: ...
    @property
    def interpreter(self) -> Interpreter: ...
    def send(self, line: Line, data: bytes, now: float, baud: int | None = None) -> None: ...


def start(
    engine: TransferEngine,
    line: Line,
    text: str,
    request: special.TransferRequest,
    now: float,
    speed: int | None,
) -> None:
    """The module sends nothing before the transfer itself (§6.16)."""
    peer: XmodemSender | XmodemReceiver
    if request.send is not None:
        peer = XmodemSender(request.send, one_k=True)
    else:
        peer = XmodemReceiver(max_size=request.max_size)
    line.transfer = Transfer(text, request.area, peer, speed)
    engine.send(line, peer.start(now / engine.scale), now, speed)


def take_input(engine: TransferEngine, line: Line, data: bytes, now: float) -> bytes:
    """Bytes of a running transfer go to XMODEM, not to the command parser; returns what is
    left for the parser."""
    transfer = line.transfer
    assert transfer is not None
    if transfer.grace_until is not None:
        if data and all(byte == EOT for byte in data):
            engine.send(line, transfer.peer.receive(data, now / engine.scale), now, transfer.speed)
            return b""
        line.transfer = None
        return data
    engine.send(line, transfer.peer.receive(data, now / engine.scale), now, transfer.speed)
    _finish(engine, line, now)
    return b""


def expire(engine: TransferEngine, line: Line, now: float) -> None:
    """The transfer's timers at ``now``: XMODEM's timeouts, then the grace after its end."""
    transfer = line.transfer
    assert transfer is not None
    if transfer.grace_until is None:
        engine.send(line, transfer.peer.advance(now / engine.scale), now, transfer.speed)
        _finish(engine, line, now)
    elif now >= transfer.grace_until:
        line.transfer = None


def _finish(engine: TransferEngine, line: Line, now: float) -> None:
    transfer = line.transfer
    assert transfer is not None
    peer = transfer.peer
    if not peer.done:
        return
    ok = peer.ok
    if ok and isinstance(peer, XmodemReceiver):
        try:
            special.apply(engine.state, transfer.area, peer.data, now)
        except (CommandError, ValueError) as exc:
            log.info("transfer of %s refused: %s", transfer.area, exc)
            ok = False
    if ok:
        engine.send(line, b"OK\r\n", now, transfer.speed)
    else:
        error = engine.interpreter.error_answer(transfer.command).data
        engine.send(line, error, now, transfer.speed)
    grace = TRANSFER_GRACE * engine.scale if isinstance(peer, XmodemReceiver) else 0.0
    transfer.grace_until = now + grace
