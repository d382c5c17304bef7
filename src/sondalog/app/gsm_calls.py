"""Calls placed by phones (the HTTP API, ``sondalog phone call``) and their data bridges.

A data call's bytes reach the person who placed it through a **bridge**: a TCP port on
127.0.0.1 the API hands out with the call (``"bridge": PORT``). The first connection to it is
the phone's side of the call: bytes written there go to the modem once it answered (earlier
ones wait), the modem's bytes come back on it; closing it hangs up, and the call ending
closes it. ``sondalog term gsm://...`` is such a connection (docs/gsm.md).

The bridges reach the running network only through :class:`PhoneSide` (the served world,
:class:`sondalog.app.gsm.GsmRuntime`, is one); it tells them each call's id as the network
gives it (:meth:`CallBridges.placed`) and what the phones hear
(:meth:`CallBridges.phone_event`).
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass, field
from typing import Any, Protocol

from sondalog.gsm.phones import CallPlaced, PhoneEvent

#: Ended calls remembered for ``GET /calls``.
KEEP_ENDED = 100
#: Bytes for the far end kept while the call is not answered yet.
MAX_EARLY = 65536


@dataclass
class CallInfo:
    call_id: int
    caller: str
    callee: str
    kind: str
    state: str = "ringing"  # ringing, connected, ended
    reason: str = ""
    bridge: int | None = None
    _server: asyncio.Server | None = None
    _writer: asyncio.StreamWriter | None = None
    _early: bytearray = field(default_factory=bytearray)  # from the far end, before a client
    _waiting: bytearray = field(default_factory=bytearray)  # to the far end, before answer

    def as_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "call": self.call_id,
            "from": self.caller,
            "to": self.callee,
            "kind": self.kind,
            "state": self.state,
        }
        if self.reason:
            out["reason"] = self.reason
        if self.bridge is not None:
            out["bridge"] = self.bridge
        return out


class PhoneSide(Protocol):
    """What the bridges ask of the running network."""

    def place_call(self, caller: str, callee: str, kind: str) -> CallPlaced:
        """Place a call; its id comes back (after :meth:`CallBridges.placed` was told)."""
        ...

    def hang_up(self, call_id: int) -> None: ...

    def call_data(self, call_id: int, data: bytes) -> None:
        """Bytes from the phone's side of an answered data call."""
        ...


class CallBridges:
    """The calls phones placed, by id."""

    def __init__(self, network: PhoneSide) -> None:
        self.network = network
        self.calls: dict[int, CallInfo] = {}

    async def place(self, caller: str, callee: str, kind: str) -> CallInfo:
        """A phone calls a modem; a data call that rings gets its bridge port."""
        info = self.calls[self.network.place_call(caller, callee, kind).call_id]
        if kind == "data" and info.state != "ended":
            await self._open_bridge(info)
        self._forget_old()
        return info

    def placed(self, reply: CallPlaced) -> None:
        """The network gave a call its id: known from now on, before its ring or its end."""
        self.calls[reply.call_id] = CallInfo(reply.call_id, reply.caller, reply.callee, reply.kind)

    def hang_up(self, call_id: int) -> None:
        self.network.hang_up(call_id)
        info = self.calls.get(call_id)
        if info is not None and info.state != "ended":
            self._ended(info, "hangup")

    def phone_event(self, event: PhoneEvent) -> None:
        info = self.calls.get(event.call_id)
        if info is None or event.kind == "sms":
            return
        if event.kind == "answered":
            info.state = "connected"
            if info._waiting:
                data, info._waiting = bytes(info._waiting), bytearray()
                self._to_far_end(info, data)
        elif event.kind == "data":
            if info._writer is not None:
                info._writer.write(event.data)
            else:
                info._early += event.data[: MAX_EARLY - len(info._early)]
        elif event.kind == "ended":
            self._ended(info, event.reason)

    def _to_far_end(self, info: CallInfo, data: bytes) -> None:
        if info.state == "connected":
            self.network.call_data(info.call_id, data)
        elif info.state == "ringing":
            info._waiting += data[: MAX_EARLY - len(info._waiting)]

    def _ended(self, info: CallInfo, reason: str) -> None:
        info.state = "ended"
        info.reason = reason
        if info._writer is not None:
            info._writer.close()
            info._writer = None
        if info._server is not None:
            info._server.close()
            info._server = None

    async def _open_bridge(self, info: CallInfo) -> None:
        async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            if info._writer is not None or info.state == "ended":
                writer.close()
                return
            info._writer = writer
            if info._early:
                writer.write(bytes(info._early))
                info._early.clear()
            try:
                while data := await reader.read(4096):
                    self._to_far_end(info, data)
            except (ConnectionError, asyncio.CancelledError):
                pass
            finally:
                if info.state != "ended":
                    self.hang_up(info.call_id)

        server = await asyncio.start_server(client, "127.0.0.1", 0)
        info.bridge = int(server.sockets[0].getsockname()[1])
        if info.state == "ended":  # it ended while the port opened
            server.close()
        else:
            info._server = server

    def _forget_old(self) -> None:
        ended = [c for c in self.calls.values() if c.state == "ended"]
        for info in ended[:-KEEP_ENDED]:
            del self.calls[info.call_id]

    async def close(self) -> None:
        for info in self.calls.values():
            if info._writer is not None:
                info._writer.close()
            if info._server is not None:
                info._server.close()
                with contextlib.suppress(Exception):
                    await info._server.wait_closed()
