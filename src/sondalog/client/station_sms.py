"""``logger config apply --via sms``: a station's settings as SMS commands, for a logger only
reachable by SMS (§6.12.1, docs/config.md), through a served GSM network's HTTP API.

Each SMS carries one command line between the ``sms command boundary`` markers (factory
``##*#``): chained writes (§7.1) packed to fit one SMS of 160 GSM-7 septets (§6.12; an
extension character such as ``[`` takes two) and one command line of 120 characters
(§3.4.1). The logger answers the line by SMS to the sender; every answer must be ``OK``
before the next SMS goes. A line is parsed whole before
anything of it runs (spec notes §3), so a refused SMS applied none of its writes.

SMS cannot read back a whole configuration cheaply, so this path writes every setting the
file gives (not a diff; writing a value the logger already holds changes nothing) and leaves
the settings the file does not give as they are.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from sondalog.client.ala1_codec import MAX_LINE
from sondalog.client.phone import PhoneApi, PhoneApiError, parse_gsm_url
from sondalog.client.station_file import Station
from sondalog.client.station_grammar import BOUNDARIES, LIMITS
from sondalog.client.station_schema import APPLY_ORDER
from sondalog.protocol.gsm7 import SMS_SEPTETS, Gsm7Error, septet_length

#: How long the logger may take to answer one SMS.
REPLY_TIMEOUT = 120.0
_LAST = ("sms command boundary", "i address")  # they change how the next SMS must look


@dataclass
class SmsOutcome:
    sent: list[str] = field(default_factory=list)  # the command lines applied
    not_sent: list[str] = field(default_factory=list)
    error: str | None = None


def _writes(station: Station) -> list[tuple[str, str]]:
    """(setting name, write command) of every setting the file gives, in apply order."""
    out: list[tuple[str, str]] = []
    late: list[tuple[str, str]] = []
    for setting in APPLY_ORDER:
        for n in range(1, setting.count(LIMITS["2.10"]) + 1):
            name = setting.name(n)
            if name not in station.values:
                continue
            dual = " all" if setting.dual else ""
            write = f"write {name}{dual}{setting.grammar.written(station.values[name])}"
            (late if setting.pattern in _LAST else out).append((name, write))
    return out + late


def _prefix(iaddress: str) -> str:
    if not iaddress:
        return ""
    boundary = next(b for b in BOUNDARIES if b not in iaddress)
    return f"iaddress{boundary}{iaddress}{boundary} "


def pack(station: Station, boundary: str, iaddress: str) -> list[list[tuple[str, str]]]:
    """The writes grouped into SMS; raises ValueError (with the file's field) for a value
    an SMS cannot carry."""
    groups: list[list[tuple[str, str]]] = []
    for name, write in _writes(station):
        try:
            septet_length(write)
        except Gsm7Error as exc:
            raise station.fail(name, f"an SMS cannot carry it: {exc}") from None
        if groups and _fits(groups[-1] + [(name, write)], boundary, iaddress):
            groups[-1].append((name, write))
            continue
        if not _fits([(name, write)], boundary, iaddress):
            raise station.fail(name, f"the write does not fit one SMS of {SMS_SEPTETS} septets")
        groups.append([(name, write)])
        if name in _LAST:  # the next SMS uses the new boundary or address
            groups.append([])
    return [g for g in groups if g]


def _fits(group: list[tuple[str, str]], boundary: str, iaddress: str) -> bool:
    """One SMS of 160 septets, carrying one command line of at most 120 characters."""
    text = _text(group, boundary, iaddress)
    return septet_length(text) <= SMS_SEPTETS and len(text) - 2 * len(boundary) <= MAX_LINE


def _text(group: list[tuple[str, str]], boundary: str, iaddress: str) -> str:
    line = _prefix(iaddress) + " ".join(write for _, write in group)
    return f"{boundary}{line}{boundary}"


def apply_by_sms(
    url: str,
    station: Station,
    explain: Callable[[str, str], str],
    *,
    reply_timeout: float = REPLY_TIMEOUT,
    report: Callable[[str], None] = lambda line: None,
) -> SmsOutcome:
    """Send the station's writes as SMS to the logger of ``gsm://API/NUMBER?from=PHONE``.

    Blocking (the phone API is plain HTTP); raises ValueError/ConfigError for a value an SMS
    cannot carry before anything is sent, :class:`PhoneApiError` when the API is away."""
    endpoint = parse_gsm_url(url)
    api = PhoneApi(endpoint.api)
    boundary = station.values.get("sms command boundary", "##*#")
    boundary_now = "##*#"  # until the file's boundary is written (it is written last)
    iaddress = station.values.get("i address", "")
    groups = pack(station, boundary, iaddress)
    outcome = SmsOutcome()
    for index, group in enumerate(groups):
        text = _text(group, boundary_now, iaddress)  # no i address yet: any is taken
        seen = max((m["id"] for m in api.inbox(endpoint.caller)), default=0)
        api.sms(endpoint.caller, endpoint.number, text)
        reply = _wait_reply(api, endpoint.caller, endpoint.number, seen, reply_timeout)
        line = text[len(boundary_now) : -len(boundary_now)]
        report(f"SMS {index + 1}/{len(groups)}: {line} -> {reply.strip() or '(no reply)'}")
        if reply.strip() != "OK":
            if not reply:
                outcome.error = f"no answer within {reply_timeout:.0f} s to the SMS {line!r}"
            else:
                outcome.error = f"the logger answered {reply.strip()!r} to the SMS {line!r}"
                if reply.strip().endswith("ERROR"):
                    outcome.error += "\n" + explain(line, "2.10")
            outcome.not_sent = [w for g in groups[index:] for _, w in g]
            return outcome
        outcome.sent += [w for _, w in group]
        names = {name for name, _ in group}
        if "sms command boundary" in names:
            boundary_now = boundary
    return outcome


def _wait_reply(api: PhoneApi, caller: str, number: str, seen: int, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            new = [m for m in api.inbox(caller) if m["id"] > seen and m["from"] == number]
        except PhoneApiError:
            new = []
        if new:
            return "".join(str(m["text"]) for m in sorted(new, key=lambda m: m["id"]))
        time.sleep(0.5)
    return ""
