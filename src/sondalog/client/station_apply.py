"""``logger config pull|plan|apply``: a station file against a logger over any line the
client knows (tcp://, serial://, gsm://; docs/config.md).

- :func:`pull`: the logger's settings (and conversion tables, by XMODEM as ``tables pull``
  does, §6.16) as a station file;
- :func:`make_plan`: what would change; a file of the other protocol version (1.16 vs 2.10)
  is translated where it can be and refused where it cannot (:class:`Refused` lists every
  setting that cannot, with its file, line and field), before anything is written;
- :func:`apply`: the plan's writes, each read back; on a refusal it stops and says which
  setting, why (the ``explain`` the caller gives: ``term``'s ``:explain``) and what was and
  was not applied.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field

from sondalog.client import tables as table_ops
from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import DEFAULT_TIMEOUT, ClientError
from sondalog.client.endpoints import SerialEndpoint, parse_url
from sondalog.client.station_file import Station, render_station
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_logger import (
    Change,
    Identity,
    Session,
    clean,
    desired_values,
    factory_display,
    identify,
    plan,
    read_command,
    read_values,
    resized,
)
from sondalog.client.station_schema import Setting, instances

#: ``explain(line, version)``: why a logger of ``version`` refuses ``line`` (``:explain``).
Explain = Callable[[str, str], str]
_BY_NAME: dict[str, tuple[Setting, int]] = {s.name(n): (s, n) for s, n in instances(LIMITS["2.10"])}


class Refused(Exception):
    """The station cannot be applied to this logger; ``problems``: one line each."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


@dataclass
class Plan:
    identity: Identity
    changes: list[Change]
    tables: dict[str, bytes] | None = None  # to send (None: left as they are)
    notes: list[str] = field(default_factory=list)  # translation between versions

    @property
    def empty(self) -> bool:
        return not self.changes and self.tables is None

    def lines(self) -> list[str]:
        out = list(self.notes)
        if self.tables is not None:
            names = ", ".join(self.tables) or "none"
            out.append(f"conversion tables: send {names} (§10.4)")
        out += [change.describe() for change in self.changes]
        return out


@dataclass
class Outcome:
    """What :func:`apply` did."""

    plan: Plan
    applied: list[str] = field(default_factory=list)
    not_applied: list[str] = field(default_factory=list)
    error: str | None = None
    warnings: list[str] = field(default_factory=list)


#: How long opening a line may take: a TCP or serial line, and a GSM data call (it rings).
CONNECT_TIMEOUT = 15.0
CALL_TIMEOUT = 90.0


async def _connect(url: str, timeout: float) -> Ala1Client:
    endpoint = parse_url(url)
    limit = CALL_TIMEOUT if url.lower().startswith("gsm:") else CONNECT_TIMEOUT
    try:
        return await asyncio.wait_for(Ala1Client.connect(endpoint, timeout), limit)
    except TimeoutError:
        raise ClientError(f"cannot reach {url}: no connection within {limit:.0f} s") from None
    except OSError as exc:
        raise ClientError(f"cannot reach {url}: {exc.strerror or exc}") from None


async def pull(
    url: str, *, all_values: bool = False, iaddress: str | None = None, tables_dir: str = ""
) -> tuple[str, dict[str, bytes]]:
    """The station file of the logger at ``url`` and its conversion tables (name -> bytes;
    the file names them ``tables_dir/NAME.txt``)."""
    client = await _connect(url, DEFAULT_TIMEOUT)
    async with client:
        session = Session(client, iaddress)
        ident = await identify(session)
        values = await read_values(session, ident.version)
        tables = await _logger_tables(session, values)
    factory = factory_display(values, ident.version, ident.serial)
    keep = {name for name, value in values.items() if all_values or value != factory[name]}
    paths = {name: f"{tables_dir}{name}.txt" for name in tables}
    text = render_station(
        values, keep, protocol=ident.version, serial=ident.serial, tables=paths or None
    )
    return text, tables


async def _logger_tables(session: Session, values: dict[str, str]) -> dict[str, bytes]:
    if values["file list size"] == "0" or values["file data size"] == "0":
        return {}
    try:
        return await table_ops.pull(session.client)
    except ValueError:  # a broken table list: nothing usable to keep
        return {}


def fit(station: Station, version: str) -> list[str]:
    """Check ``station`` against a logger of ``version``; notes of what was translated.

    Raises :class:`Refused` naming every setting the logger cannot take."""
    limits = LIMITS[version]
    problems: list[str] = []
    dropped: list[str] = []
    for name, value in station.values.items():
        setting, n = _BY_NAME[name]
        if n > setting.count(limits):
            default = setting.default_for(station.values, n, "")
            if value == default:
                dropped.append(name)
                continue
            problems.append(str(station.fail(name, f"a {version} logger has no {name}")))
            continue
        try:
            for part in value.split(",") if setting.dual else [value]:
                setting.grammar.check(part, limits)
        except ValueError as exc:
            problems.append(str(station.fail(name, f"a {version} logger refuses it: {exc}")))
    if problems:
        raise Refused(problems)
    notes = []
    if station.protocol and station.protocol != version:
        notes.append(
            f"the file is for protocol {station.protocol}, the logger speaks {version}:"
            f" {len(station.values) - len(dropped)} settings carry over unchanged"
        )
        if dropped:
            notes.append(f"left out (factory values, not in {version}): {', '.join(dropped)}")
    return notes


async def _make_plan(session: Session, station: Station) -> Plan:
    ident = await identify(session)
    if station.serial_number and station.serial_number != ident.serial:
        raise Refused(
            [f"the file is for logger {station.serial_number}; this is logger {ident.serial}"]
        )
    notes = fit(station, ident.version)
    actual = await read_values(session, ident.version)
    given = {n: v for n, v in station.values.items() if _BY_NAME[n][1] <= _count(n, ident)}
    desired = desired_values(given, ident.version, ident.serial)
    changes = plan(actual, desired, ident.version)
    wanted = station.table_bodies()
    send = None
    if wanted is not None:
        have = await _logger_tables(session, actual)
        if wanted != have or (wanted and resized(changes)):
            send = wanted
    return Plan(ident, changes, send, notes)


def _count(name: str, ident: Identity) -> int:
    setting, _ = _BY_NAME[name]
    return setting.count(LIMITS[ident.version])


async def make_plan(url: str, station: Station, *, iaddress: str | None = None) -> Plan:
    """What :func:`apply` would write to the logger at ``url``."""
    client = await _connect(url, DEFAULT_TIMEOUT)
    async with client:
        return await _make_plan(Session(client, _address(station, iaddress)), station)


def _address(station: Station, iaddress: str | None) -> str | None:
    return iaddress if iaddress is not None else station.values.get("i address") or None


async def apply(
    url: str, station: Station, explain: Explain, *, iaddress: str | None = None
) -> Outcome:
    """Write what differs, each write verified by reading it back (see the module doc)."""
    client = await _connect(url, DEFAULT_TIMEOUT)
    async with client:
        session = Session(client, _address(station, iaddress))
        current = await _make_plan(session, station)
        outcome = Outcome(current)
        serial = isinstance(client.endpoint, SerialEndpoint)
        steps: list[Change | None] = list(current.changes)
        if current.tables is not None:  # right after the memory partition (§6.15)
            first = [c for c in current.changes if c.setting.group == "file"]
            steps.insert(len(first), None)
        if serial:  # the line changes speed with com speed: nothing can follow it there
            steps.sort(key=lambda s: s is not None and s.setting.pattern == "com speed")
        for index, step in enumerate(steps):
            error = await _step(session, step, current, outcome, explain, serial)
            if error is not None:
                outcome.error = error
                outcome.not_applied = [_label(s) for s in steps[index:]]
                break
            outcome.applied.append(_label(step))
        return outcome


def _label(step: Change | None) -> str:
    return "conversion tables" if step is None else step.describe()


async def _step(
    session: Session,
    step: Change | None,
    current: Plan,
    outcome: Outcome,
    explain: Explain,
    serial: bool,
) -> str | None:
    """One write and its read-back; the reason it failed, or None."""
    if step is None:
        assert current.tables is not None
        try:
            await table_ops.push(session.client, current.tables)
        except (ValueError, ClientError) as exc:
            return f"conversion tables: {exc}"
        return None
    line = step.command()
    answer = await session.command(line)
    if not answer.ok:
        why = explain(session.prefix() + line, current.identity.version)
        return f"{step.name}: the logger refused {line!r}\n{why}"
    if step.setting.pattern == "i address":
        session.iaddress = step.value or None
    if step.setting.pattern == "com speed" and serial:
        outcome.warnings.append(f"com speed is now {step.value}: reconnect at that rate")
        return None
    back = await session.command(read_command(step.setting, step.n))
    got = clean(step.setting, back.lines[0]) if back.ok and len(back.lines) == 1 else None
    if got != step.new:
        return f"{step.name}: written, but it reads back {got!r}, not {step.new!r}"
    return None


__all__ = ["Outcome", "Plan", "Refused", "apply", "fit", "make_plan", "pull"]
