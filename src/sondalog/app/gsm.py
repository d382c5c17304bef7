"""The GSM network of a site, running (``sondalog serve`` with a ``[gsm]`` table; docs/gsm.md).

Wiring only: the pure cores (:mod:`sondalog.gsm`) adapted to the Device contract
(:mod:`sondalog.world.gsm_devices`) and served by the one runtime, one
:class:`~sondalog.io.host.DeviceHost` per modem (its DTE lines: a pty, TCP) and one for the
network (its timers: outages, unanswered calls, signal and credit models). A modem's effects
are posted to the network's host; what the network says is carried by the one router
(:func:`sondalog.gsm.routing.route`, as in the pure :class:`~sondalog.gsm.system.GsmSystem`)
to the destinations :class:`GsmRuntime` implements: events posted to the modems' hosts,
phone events to the call bridges (:mod:`sondalog.app.gsm_calls`), the IP gateway's effects
to real TCP (:class:`~sondalog.io.sockets.SocketPool`). The phone side (the HTTP API,
:mod:`sondalog.app.gsm_api`, and the call bridges) posts its requests to the network's host
and gets the ids the network gave back in its output. The network's durable state is
written to ``STATE/network.json`` after every change and read back at start (SMS survive a
restart).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
from collections.abc import Callable
from pathlib import Path
from typing import IO, TypeVar

from sondalog.app.gsm_calls import CallBridges
from sondalog.app.gsm_site import GsmPlan
from sondalog.gsm import events as ev
from sondalog.gsm import gateway as gw
from sondalog.gsm import netstate
from sondalog.gsm.config import build
from sondalog.gsm.network import Network
from sondalog.gsm.phones import (
    CallPlaced,
    Coverage,
    PhoneCall,
    PhoneData,
    PhoneEvent,
    PhoneHangUp,
    PhoneSms,
    Request,
    SmsSubmitted,
)
from sondalog.gsm.routing import NetOutput, route
from sondalog.gsm.trace import trace_line
from sondalog.io.clock import Clock
from sondalog.io.host import DeviceHost, LocalLink
from sondalog.io.private import open_private, private_dir, private_parents
from sondalog.io.pty import PtyLine
from sondalog.io.sockets import SocketPool
from sondalog.io.tcp import TcpServer, serve_tcp
from sondalog.protocol.device import Effect
from sondalog.world.gsm_devices import (
    FromNetwork,
    IpHappened,
    ModemDevice,
    ModemSaid,
    NetworkDevice,
    NetworkSaid,
    Requested,
    ToNetwork,
)

T = TypeVar("T")
log = logging.getLogger(__name__)

STATE_FILE = "network.json"
#: Seconds after a change before the network's state is written.
SAVE_DELAY = 0.05


class _IpEvents:
    """Socket callbacks -> events for the network's host."""

    def __init__(self, runtime: GsmRuntime) -> None:
        self.runtime = runtime

    def _post(self, event: gw.IpEvent) -> None:
        self.runtime.net_host.post(IpHappened(event))

    def connected(self, conn: int) -> None:
        self._post(gw.Connected(conn))

    def failed(self, conn: int) -> None:
        self._post(gw.ConnectFailed(conn))

    def data(self, conn: int, data: bytes) -> None:
        self._post(gw.Received(conn, data))

    def closed(self, conn: int) -> None:
        self._post(gw.Closed(conn))

    def accepted(self, listener: int, conn: int) -> None:
        self._post(gw.Accepted(listener, conn))


class GsmRuntime:
    """A served GSM world: start with :meth:`start`, stop with :meth:`close`."""

    def __init__(self, plan: GsmPlan, state: Path, clock: Clock) -> None:
        self.plan = plan
        self.state = state
        self.clock = clock
        self.modem_hosts: dict[str, DeviceHost] = {}
        self.modem_devices: dict[str, ModemDevice] = {}
        self.ptys: list[PtyLine] = []
        self.servers: dict[str, TcpServer] = {}
        self.sockets = SocketPool(_IpEvents(self))
        self.calls = CallBridges(self)
        self._traces: list[IO[str]] = []
        self._save_handle: asyncio.TimerHandle | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._submitted: list[SmsSubmitted] = []  # answers to the request being posted
        self._placed: list[CallPlaced] = []
        self.network = Network()
        self.net_host: DeviceHost

    # -- start and stop --------------------------------------------------------------------
    async def start(self) -> None:
        private_dir(self.state)  # 0700, its files 0600 (docs/security.md)
        now = self.clock.now()
        system = build(self.plan.config, now, trace=self._tracer)
        self.network = system.network
        restored: list[NetOutput] = []
        path = self.state / STATE_FILE
        if path.exists():
            data = json.loads(path.read_text(encoding="utf-8"))
            restored = netstate.load(self.network, data, now)
        device = NetworkDevice(self.network, now, self.plan.signals, self.plan.credits)
        self.net_host = DeviceHost(device, self.clock)
        self.net_host.on_effect(NetworkSaid, self._network_said)
        for number, modem in system.modems.items():
            modem_device = ModemDevice(number, modem)
            host = DeviceHost(modem_device, self.clock)
            host.on_effect(ToNetwork, self._to_network)
            self.modem_devices[number] = modem_device
            self.modem_hosts[number] = host
            host.start()
        self.net_host.start()
        route(restored, self)
        self.changed()
        for serve in self.plan.modems:
            host = self.modem_hosts[serve.number]
            if serve.pty is not None:
                self.ptys.append(PtyLine(host, serve.pty))
            if serve.listen is not None:
                self.servers[serve.number] = await serve_tcp(host, *serve.listen)
        self.save()

    async def close(self) -> None:
        if self._save_handle is not None:
            self._save_handle.cancel()
        with contextlib.suppress(Exception):
            self.save()
        await self.calls.close()
        for pty in self.ptys:
            pty.close()
        for server in self.servers.values():
            with contextlib.suppress(Exception):
                await server.close()
        await self.sockets.close_all()
        for host in self.modem_hosts.values():
            await host.stop()
        if hasattr(self, "net_host"):
            await self.net_host.stop()
        for task in list(self._tasks):
            task.cancel()
        for trace in self._traces:
            trace.close()

    def dte(self, number: str, on_data: Callable[[bytes], None]) -> LocalLink:
        """An in-process DTE line of modem ``number`` (the logger's com line, joined by the
        wiring): ``link.write(bytes)`` goes to the modem, its output goes to ``on_data``,
        paced at the modem's serial speed."""
        return self.modem_hosts[number].link(on_data, paced=True)

    def _tracer(self, number: str) -> Callable[[str, bytes, float], None] | None:
        target = next((m.trace for m in self.plan.modems if m.number == number), None)
        if target is None:
            return None
        target = self.state / target  # a relative path is in the state directory
        private_parents(target)
        # a trace holds the logger's line (mail passwords): private wherever it is written
        file = open_private(target, "a", buffering=1)
        self._traces.append(file)

        def hook(direction: str, data: bytes, now: float) -> None:
            file.write(trace_line(direction, data, now))

        return hook

    # -- the phone side: requests posted to the network's host ------------------------------
    def send_sms(self, sender: str, to: str, text: str) -> SmsSubmitted:
        """A phone sends an SMS; the answer carries the ids the SMS centre gave it."""
        self._submitted.clear()
        return _answer(self._submitted, self._post(PhoneSms(sender, to, text)))

    def place_call(self, caller: str, callee: str, kind: str) -> CallPlaced:
        """A phone calls; the answer carries the call's id (the call bridges knew it first)."""
        self._placed.clear()
        return _answer(self._placed, self._post(PhoneCall(caller, callee, kind)))

    def hang_up(self, call_id: int) -> None:
        self._post(PhoneHangUp(call_id))

    def call_data(self, call_id: int, data: bytes) -> None:
        self._post(PhoneData(call_id, data))

    def set_coverage(self, number: str | None, covered: bool) -> None:
        self._post(Coverage(number, covered))

    def _post(self, request: Request) -> Request:
        """``request`` for the network's host, which runs it at once (routing its output, an
        answer among it) and looks at its next deadline again."""
        self.net_host.post(Requested(request))
        self.changed()
        return request

    # -- routing: the destinations of the network's output ----------------------------------
    def _network_said(self, effect: Effect) -> None:
        assert isinstance(effect, NetworkSaid)
        route((effect.output,), self)

    def _to_network(self, effect: Effect) -> None:
        assert isinstance(effect, ToNetwork)
        self.net_host.post(ModemSaid(effect.number, effect.effect))
        self.changed()

    def to_modem(self, number: str, event: ev.Event) -> None:
        host = self.modem_hosts.get(number)
        if host is not None:
            host.post(FromNetwork(event))

    def to_phone(self, event: PhoneEvent) -> None:
        self.calls.phone_event(event)
        self.changed()

    def sms_submitted(self, reply: SmsSubmitted) -> None:
        self._submitted.append(reply)

    def call_placed(self, reply: CallPlaced) -> None:
        self.calls.placed(reply)
        self._placed.append(reply)

    def to_ip(self, effect: gw.IpEffect) -> None:
        match effect:
            case gw.Connect(conn, host, port):
                self.sockets.connect(conn, host, port)
            case gw.Send(conn, data):
                self.sockets.send(conn, data)
            case gw.Close(conn):
                self.sockets.close(conn)
            case gw.Listen(listener, host, port):
                self.spawn(self.sockets.listen(listener, host, port))
            case gw.Unlisten(listener):
                self.sockets.unlisten(listener)

    def spawn(self, coro: object) -> None:
        task: asyncio.Task[None] = asyncio.get_running_loop().create_task(coro)  # type: ignore[arg-type]
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- durable state ---------------------------------------------------------------------
    def changed(self) -> None:
        """Something may have changed: write the state soon."""
        if self._save_handle is None:
            loop = asyncio.get_running_loop()
            self._save_handle = loop.call_later(SAVE_DELAY, self.save)

    def save(self) -> None:
        """Write the network's durable state atomically (``STATE/network.json``)."""
        self._save_handle = None
        path = self.state / STATE_FILE
        tmp = path.with_suffix(".tmp")
        with open_private(tmp) as file:
            json.dump(netstate.dump(self.network), file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(tmp, path)


def _answer(answers: list[T], request: Request) -> T:
    """The network's answer to ``request``."""
    if not answers:
        raise RuntimeError(f"the network did not answer {request!r} (see the log)")
    return answers.pop()
