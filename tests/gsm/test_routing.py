"""The network's typed output and its one router (gsm/routing.py): the pure composition
(GsmSystem) and the served one (app/gsm.GsmRuntime, its DeviceHosts in-process on a stepped
clock) carry the same requests to the same deliveries; the HTTP API gets an SMS's ids from
the network's output."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from sondalog.app.gsm import GsmRuntime
from sondalog.app.gsm_api import ApiServer
from sondalog.app.gsm_site import GsmPlan, parse_gsm_site
from sondalog.client.phone import PhoneApi
from sondalog.config import loads
from sondalog.gsm import events as ev
from sondalog.gsm import netstate
from sondalog.gsm.config import build
from sondalog.gsm.gateway import Close, Connect, IpEffect, ModemEvent
from sondalog.gsm.network import Network
from sondalog.gsm.phones import (
    CallPlaced,
    Coverage,
    PhoneCall,
    PhoneEvent,
    PhoneHangUp,
    PhoneSms,
    Request,
    SmsSubmitted,
)
from sondalog.gsm.routing import NetOutput, route
from sondalog.io.clock import SteppedClock

T0 = 1_764_460_800.0
MODEM = "+420600000001"
PHONE = "+420700000001"
SITE = f"""
[gsm]
[[gsm.modem]]
number = "{MODEM}"
[[gsm.phone]]
number = "{PHONE}"
"""
#: What the phone side asks, in order (the call's id is filled in when it is known).
STEPS: list[Request] = [
    PhoneSms(PHONE, MODEM, "hi"),
    Coverage(MODEM, False),
    PhoneSms(PHONE, MODEM, "later " * 40),  # concatenated, waits for coverage
    Coverage(MODEM, True),
    PhoneCall(PHONE, MODEM, "voice"),
    PhoneHangUp(0),
    PhoneSms(PHONE, "0042" + PHONE[3:], "to a phone"),
]


class Recorder:
    """Destinations that write down what arrives, in order."""

    def __init__(self) -> None:
        self.got: list[tuple[str, object]] = []

    def to_modem(self, number: str, event: ev.Event) -> None:
        self.got.append(("modem", (number, event)))

    def to_phone(self, event: PhoneEvent) -> None:
        self.got.append(("phone", event))

    def to_ip(self, effect: IpEffect) -> None:
        self.got.append(("ip", effect))

    def sms_submitted(self, reply: SmsSubmitted) -> None:
        self.got.append(("submitted", reply))

    def call_placed(self, reply: CallPlaced) -> None:
        self.got.append(("placed", reply))


def test_route_carries_each_kind_in_order() -> None:
    placed = CallPlaced(1, PHONE, MODEM, "data")
    submitted = SmsSubmitted(PHONE, MODEM, (1, 2), False)
    ended = PhoneEvent(PHONE, "ended", 1, reason="busy")
    outputs: list[NetOutput] = [
        placed,
        ModemEvent(MODEM, ev.Signal(9)),
        Connect(3, "127.0.0.1", 25),
        ended,
        submitted,
        Close(3),
    ]
    recorder = Recorder()
    route(outputs, recorder)
    assert recorder.got == [
        ("placed", placed),
        ("modem", (MODEM, ev.Signal(9))),
        ("ip", Connect(3, "127.0.0.1", 25)),
        ("phone", ended),
        ("submitted", submitted),
        ("ip", Close(3)),
    ]


def test_request_answers_with_the_ids_the_network_gave() -> None:
    network = Network()
    network.add_phone(PHONE)
    network.add_modem(MODEM, T0)
    out = network.request(PhoneSms(PHONE, MODEM, "x" * 200), T0)
    assert out[-1] == SmsSubmitted(PHONE, MODEM, (1, 2), False)  # on its way: not queued
    network.set_coverage(MODEM, False, T0)
    assert network.request(PhoneSms(PHONE, MODEM, "y"), T0)[-1].queued  # type: ignore[union-attr]
    out = network.request(PhoneCall(PHONE, MODEM, "voice"), T0)
    assert out[0] == CallPlaced(1, PHONE, MODEM, "voice")  # before the call's own end
    assert out[1] == PhoneEvent(PHONE, "ended", 1, reason="unreachable")


def _plan(tmp_path: Path) -> GsmPlan:
    return parse_gsm_site(loads(SITE, tmp_path / "site.toml"), T0)


def _pure(plan: GsmPlan) -> tuple[list[Any], dict[str, Any]]:
    """Each step through the pure composition: (answers, modem line, phone events)."""
    system = build(plan.config, T0)
    seen: list[Any] = []
    call_id = 0
    for step in STEPS:
        request = PhoneHangUp(call_id) if isinstance(step, PhoneHangUp) else step
        out = system.request(request, T0)
        call_id = out.placed[0].call_id if out.placed else call_id
        seen.append((out.submitted, out.placed, out.line(MODEM), out.phones))
    return seen, netstate.dump(system.network)


def _served(plan: GsmPlan, state: Path) -> tuple[list[Any], dict[str, Any]]:
    """The same steps through the served composition (GsmRuntime, its hosts)."""

    async def run() -> tuple[list[Any], dict[str, Any]]:
        runtime = GsmRuntime(plan, state, SteppedClock(T0))
        await runtime.start()
        line = bytearray()
        phones: list[PhoneEvent] = []
        heard = runtime.to_phone

        def to_phone(event: PhoneEvent) -> None:
            phones.append(event)
            heard(event)

        runtime.to_phone = to_phone  # type: ignore[method-assign]
        runtime.modem_hosts[MODEM].link(line.extend)  # an unpaced DTE line
        seen: list[Any] = []
        call_id = 0
        try:
            for step in STEPS:
                submitted: list[SmsSubmitted] = []
                placed: list[CallPlaced] = []
                match step:
                    case PhoneSms(sender, to, text):
                        submitted.append(runtime.send_sms(sender, to, text))
                    case PhoneCall(caller, callee, kind):
                        placed.append(runtime.place_call(caller, callee, kind))
                        call_id = placed[0].call_id
                    case PhoneHangUp():
                        runtime.hang_up(call_id)
                    case Coverage(number, covered):
                        runtime.set_coverage(number, covered)
                seen.append((submitted, placed, bytes(line), list(phones)))
                line.clear()
                phones.clear()
            return seen, netstate.dump(runtime.network)
        finally:
            await runtime.close()

    return asyncio.run(run())


def test_the_pure_and_the_served_world_deliver_the_same(tmp_path: Path) -> None:
    """One router, two compositions: the same requests give the same answers, the same
    bytes on the modem's line, the same phone events and the same network state."""
    plan = _plan(tmp_path)
    pure, pure_state = _pure(plan)
    served, served_state = _served(plan, tmp_path / "state")
    assert served == pure
    assert served_state == pure_state
    # the steps did something: ids, a queued SMS, a ring and its end
    (first,), _, line, _ = pure[0]
    assert first.sms_ids == (1,) and b'+CMTI: "SM",1' in line
    assert pure[2][0][0].queued and len(pure[2][0][0].sms_ids) > 1
    assert b"RING" in pure[4][2] and pure[4][1][0].call_id == 1
    assert [p.kind for p in pure[6][3]] == ["sms"]


def test_the_api_gives_the_ids_of_the_networks_answer(tmp_path: Path) -> None:
    """``POST /sms`` answers with the ids in the network's SmsSubmitted, whatever they are:
    here the runtime's destination changes them on the way, and the API says so."""
    plan = _plan(tmp_path)

    async def run() -> tuple[dict[str, Any], list[SmsSubmitted]]:
        runtime = GsmRuntime(plan, tmp_path / "state", SteppedClock(T0))
        await runtime.start()
        api = ApiServer(runtime, "127.0.0.1", 0)
        await api.start()
        answers: list[SmsSubmitted] = []

        def sms_submitted(reply: SmsSubmitted) -> None:
            answers.append(reply)
            runtime._submitted.append(SmsSubmitted(reply.sender, reply.to, (777,), True))

        runtime.sms_submitted = sms_submitted  # type: ignore[method-assign]
        try:
            host, port = api.address
            phone = PhoneApi(f"http://{host}:{port}")
            answer = await asyncio.to_thread(phone.sms, PHONE, MODEM, "hi")
            return answer, answers
        finally:
            await api.stop()
            await runtime.close()

    answer, answers = asyncio.run(run())
    assert answers == [SmsSubmitted(PHONE, MODEM, (1,), False)]
    assert answer == {"ids": [777], "queued": True}
