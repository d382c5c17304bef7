"""The GSM network of a site, running (``sondalog serve`` with a ``[gsm]`` table; docs/gsm.md).

Wiring only: the pure cores (:mod:`sondalog.gsm`) adapted to the Device contract
(:mod:`sondalog.world.gsm_devices`) and served by the one runtime, one
:class:`~sondalog.io.host.DeviceHost` per modem (its DTE lines: a pty, TCP) and one for the
network (its timers: outages, unanswered calls, signal and credit models). Effects cross
between them through handlers; the IP gateway's effects become real TCP
(:class:`~sondalog.io.sockets.SocketPool`); the network's durable state is written to
``STATE/network.json`` after every change and read back at start (SMS survive a restart).
The HTTP API (:mod:`sondalog.app.gsm_api`) and data-call bridges work on :class:`GsmRuntime`.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import IO

from sondalog.app.gsm_calls import CallBridges
from sondalog.app.gsm_site import GsmPlan
from sondalog.gsm import gateway as gw
from sondalog.gsm import netstate
from sondalog.gsm.config import build
from sondalog.gsm.network import Network
from sondalog.gsm.trace import trace_line
from sondalog.io.clock import Clock
from sondalog.io.host import DeviceHost, LocalLink
from sondalog.io.private import open_private, private_dir, private_parents
from sondalog.io.pty import PtyLine
from sondalog.io.sockets import SocketPool
from sondalog.io.tcp import TcpServer, serve_tcp
from sondalog.protocol.device import Effect, Event
from sondalog.world.gsm_devices import (
    ForPhone,
    FromNetwork,
    IpAction,
    IpHappened,
    ModemDevice,
    ModemSaid,
    NetworkDevice,
    ToModem,
    ToNetwork,
    wrap,
)

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
        self.network = Network()
        self.net_host: DeviceHost

    # -- start and stop --------------------------------------------------------------------
    async def start(self) -> None:
        private_dir(self.state)  # 0700, its files 0600 (docs/security.md)
        now = self.clock.now()
        system = build(self.plan.config, now, trace=self._tracer)
        self.network = system.network
        restored: list[object] = []
        path = self.state / STATE_FILE
        if path.exists():
            data = json.loads(path.read_text(encoding="utf-8"))
            restored = netstate.load(self.network, data, now)
        device = NetworkDevice(self.network, now, self.plan.signals, self.plan.credits)
        self.net_host = DeviceHost(device, self.clock)
        self.net_host.on_effect(ToModem, self._to_modem)
        self.net_host.on_effect(ForPhone, self._for_phone)
        self.net_host.on_effect(IpAction, self._ip_action)
        for number, modem in system.modems.items():
            modem_device = ModemDevice(number, modem)
            host = DeviceHost(modem_device, self.clock)
            host.on_effect(ToNetwork, self._to_network)
            self.modem_devices[number] = modem_device
            self.modem_hosts[number] = host
            host.start()
        self.net_host.start()
        self.route(wrap(restored))
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

    # -- routing ---------------------------------------------------------------------------
    def route(self, effects: Sequence[Effect]) -> None:
        """Carry what a network call produced to modems, phones and sockets."""
        for effect in effects:
            if isinstance(effect, ToModem):
                self._to_modem(effect)
            elif isinstance(effect, ForPhone):
                self._for_phone(effect)
            elif isinstance(effect, IpAction):
                self._ip_action(effect)
        self.changed()

    def network_call(self, items: list[object]) -> None:
        """Route what a :class:`Network` method called by the API returned."""
        self.route(wrap(items))
        self.net_host.post(_Nudge())  # its next deadline may have moved

    def _to_network(self, effect: Effect) -> None:
        assert isinstance(effect, ToNetwork)
        self.net_host.post(ModemSaid(effect.number, effect.effect))
        self.changed()

    def _to_modem(self, effect: Effect) -> None:
        assert isinstance(effect, ToModem)
        host = self.modem_hosts.get(effect.number)
        if host is not None:
            host.post(FromNetwork(effect.event))

    def _for_phone(self, effect: Effect) -> None:
        assert isinstance(effect, ForPhone)
        self.calls.phone_event(effect.event)
        self.changed()

    def _ip_action(self, effect: Effect) -> None:
        assert isinstance(effect, IpAction)
        action = effect.effect
        if isinstance(action, gw.Connect):
            self.sockets.connect(action.conn, action.host, action.port)
        elif isinstance(action, gw.Send):
            self.sockets.send(action.conn, action.data)
        elif isinstance(action, gw.Close):
            self.sockets.close(action.conn)
        elif isinstance(action, gw.Listen):
            self.spawn(self.sockets.listen(action.listener, action.host, action.port))
        elif isinstance(action, gw.Unlisten):
            self.sockets.unlisten(action.listener)

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


class _Nudge(Event):
    """An event the network ignores: makes its host look at the next deadline again."""

    __slots__ = ()
