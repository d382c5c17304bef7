"""The network's durable state as JSON-ready data, so a restarted network process loses no
SMS (issue 12 "faults": the network process restarted).

What survives: every subscriber's SMS queue and delivered SMS, credit, signal, USSD texts,
coverage set on demand, scheduled outages, undeliverable SMS and the id counters. Calls and
TCP connections do not (a restart drops them, as a network failure would). Subscribers
themselves come from the site file: state of a number no longer subscribed is ignored.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from sondalog.gsm.network import Network, Outage
from sondalog.gsm.pdu import Concat
from sondalog.gsm.routing import NetOutput
from sondalog.gsm.sms import Sms

VERSION = 1


def _sms(sms: Sms) -> dict[str, Any]:
    concat = sms.concat
    return {
        "id": sms.sms_id,
        "from": sms.sender,
        "to": sms.to,
        "text": sms.text,
        "timestamp": sms.timestamp,
        "alphabet": sms.alphabet,
        "concat": None if concat is None else [concat.ref, concat.total, concat.seq, concat.wide],
    }


def _unsms(d: dict[str, Any]) -> Sms:
    c = d.get("concat")
    concat = None if c is None else Concat(int(c[0]), int(c[1]), int(c[2]), bool(c[3]))
    return Sms(
        int(d["id"]),
        str(d["from"]),
        str(d["to"]),
        str(d["text"]),
        int(d["timestamp"]),
        str(d.get("alphabet", "gsm7")),
        concat,
    )


def dump(network: Network) -> dict[str, Any]:
    """The durable part of ``network`` as plain data (``json.dumps`` takes it)."""
    return {
        "version": VERSION,
        "next_sms": network._next_sms,
        "concat_ref": network._concat_ref,
        "coverage": dict(network._manual_cover),
        "outages": [[o.start, o.end, o.number] for o in network.outages],
        "undeliverable": [_sms(s) for s in network.undeliverable],
        "subscribers": {
            number: {
                "credit": sub.credit,
                "rssi": sub.rssi,
                "ussd": dict(sub.ussd),
                "queue": [_sms(s) for s in sub.queue],
                "delivered": [_sms(s) for s in sub.delivered],
            }
            for number, sub in network.subscribers.items()
        },
    }


def load(network: Network, data: dict[str, Any], now: float) -> list[NetOutput]:
    """Put dumped state into a freshly built ``network`` (its subscribers already added);
    returns the outputs of re-evaluating coverage (queued SMS go out if reachable)."""
    if data.get("version") != VERSION:
        raise ValueError(f"unknown network state version {data.get('version')!r}")
    network._next_sms = max(network._next_sms, int(data.get("next_sms", 1)))
    network._concat_ref = int(data.get("concat_ref", 0))
    network.outages = [Outage(float(a), float(b), n) for a, b, n in data.get("outages", [])]
    network.undeliverable = [_unsms(s) for s in data.get("undeliverable", [])]
    for number, covered in data.get("coverage", {}).items():
        if number in network.subscribers:
            network._manual_cover[number] = bool(covered)
    out: list[NetOutput] = []
    for number, state in data.get("subscribers", {}).items():
        sub = network.subscribers.get(number)
        if sub is None:
            continue
        sub.credit = float(state.get("credit", sub.credit))
        sub.rssi = int(state.get("rssi", sub.rssi))
        sub.ussd.update({str(k): str(v) for k, v in state.get("ussd", {}).items()})
        sub.queue = deque(_unsms(s) for s in state.get("queue", []))
        sub.delivered = [_unsms(s) for s in state.get("delivered", [])]
        sub.in_flight.clear()
    out += network.advance(now)
    return out
