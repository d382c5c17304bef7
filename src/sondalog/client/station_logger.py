"""A logger's configuration as the station model sees it: read, compare, write (§6).

- :func:`identify`: the protocol version and serial number (§6.3.1, §6.3.3), or
  :class:`NotALogger` when the other end does not answer like an ALA1;
- :func:`read_values`: every setting of :mod:`sondalog.client.station_schema`, read with
  chained ``read`` commands (§7) in lines of at most 120 characters
  (:mod:`sondalog.client.station_read`);
- :func:`desired_values`: a station's settings over the factory values (§11);
- :func:`plan`: the writes that make the logger so, in an order it accepts, taking the side
  effects of writes into account (a device type restores its calibration, §6.4.4.3; the
  record size zeroes the other areas, §6.15.1).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ClientError, Response
from sondalog.client.station_grammar import BOUNDARIES, LIMITS, render_number
from sondalog.client.station_read import clean as clean  # also here, as before
from sondalog.client.station_read import exchange, read_plan
from sondalog.client.station_read import read_command as read_command
from sondalog.client.station_schema import APPLY_ORDER, FACTORY_CAL, Setting, instances


class NotALogger(ClientError):
    """The other end does not answer like an ALA1 logger."""


class Session:
    """A client plus the ``iaddress`` header every line carries once the logger has an
    ``i address`` (§8.6.1: a logger without one accepts any)."""

    def __init__(self, client: Ala1Client, iaddress: str | None = None) -> None:
        self.client = client
        self.iaddress = iaddress

    def prefix(self) -> str:
        if not self.iaddress:
            return ""
        boundary = next(b for b in BOUNDARIES if b not in self.iaddress)
        return f"iaddress{boundary}{self.iaddress}{boundary} "

    async def command(self, text: str) -> Response:
        return await self.client.command(self.prefix() + text)

    async def pipeline(self, lines: list[str]) -> list[Response]:
        return await self.client.pipeline([self.prefix() + line for line in lines])


@dataclass(frozen=True)
class Identity:
    version: str
    serial: str


async def identify(session: Session) -> Identity:
    """§6.3.1, §6.3.3; :class:`NotALogger` for anything that does not answer so."""
    try:
        answer = await session.command("read i version read i snumber")
    except ClientError as exc:
        raise NotALogger(
            f"no ALA1 answer to read i version: not a logger, or one whose i address guards"
            f" it (--iaddress, §8.6.1): {exc}"
        ) from None
    if not answer.ok or len(answer.lines) != 2 or answer.lines[0] not in LIMITS:
        raise NotALogger(f"not an ALA1 logger: it answered {answer.raw[:60]!r} to read i version")
    return Identity(answer.lines[0], answer.lines[1])


async def read_values(session: Session, version: str) -> dict[str, str]:
    """Every setting's value as the logger reads it back (file order), read in few full lines
    (:mod:`sondalog.client.station_read`)."""
    plan = read_plan(version, session.prefix())
    return plan.values(await exchange(session.client, plan.lines, plan.prefix))


def desired_values(given: Mapping[str, str], version: str, serial: str) -> dict[str, str]:
    """Every setting: the ``given`` ones (canonical), the others at their factory values.

    Defaults that depend on other settings (a device's calibration on its type) are taken
    from the values being built, in file order (the type comes first)."""
    values: dict[str, str] = {}
    for setting, n in instances(LIMITS[version]):
        name = setting.name(n)
        values[name] = given[name] if name in given else setting.default_for(values, n, serial)
    return values


def display(setting: Setting, n: int, value: str, values: Mapping[str, str]) -> str:
    """``value`` as the logger would read it back with ``values`` (numbers in their format)."""
    if setting.fmt is None:
        return value
    fmt = setting.fmt(values, n)
    return ",".join(render_number(part, fmt) for part in value.split(","))


def factory_display(values: Mapping[str, str], version: str, serial: str) -> dict[str, str]:
    """What each setting would read at its factory value, given the others (for ``pull``)."""
    out: dict[str, str] = {}
    for setting, n in instances(LIMITS[version]):
        name = setting.name(n)
        default = setting.default_for(values, n, serial)
        out[name] = display(setting, n, default, values)
    return out


@dataclass(frozen=True)
class Change:
    """One write of a plan."""

    setting: Setting
    n: int
    old: str  # as the logger reads it now
    new: str  # as it will read it
    value: str  # canonical value written

    @property
    def name(self) -> str:
        return self.setting.name(self.n)

    def command(self) -> str:
        dual = " all" if self.setting.dual else ""
        return f"write {self.name}{dual}{self.setting.grammar.written(self.value)}"

    def describe(self) -> str:
        note = f"  ({self.setting.note})" if self.setting.note else ""
        return f"{self.name}: {self.old or '(empty)'} -> {self.new or '(empty)'}{note}"


def _side_effects(change: Change, now: dict[str, str]) -> None:
    """What a write does to other settings, as the logger does it."""
    pattern = change.setting.pattern
    if pattern == "device {dev} type":
        mult, add = FACTORY_CAL[change.value]
        now[f"device {change.n} cal mult"] = render_number(mult, "0.6")
        now[f"device {change.n} cal add"] = render_number(add, "0.6")
    elif pattern == "file record size":
        now["file list size"] = now["file data size"] = "0"
    elif pattern == "file list size":
        now["file data size"] = "0"


def plan(actual: Mapping[str, str], desired: Mapping[str, str], version: str) -> list[Change]:
    """The writes that turn ``actual`` (read back) into ``desired`` (canonical), in the
    order of :data:`~sondalog.client.station_schema.APPLY_ORDER`."""
    limits = LIMITS[version]
    now = dict(actual)
    changes: list[Change] = []
    for setting in APPLY_ORDER:
        for n in range(1, setting.count(limits) + 1):
            name = setting.name(n)
            want = display(setting, n, desired[name], desired)
            if now[name] == want:
                continue
            change = Change(setting, n, now[name], want, desired[name])
            changes.append(change)
            now[name] = want
            _side_effects(change, now)
    return changes


def resized(changes: list[Change]) -> bool:
    """Whether the plan rewrites the memory partition (the tables must be sent again)."""
    return any(c.setting.group == "file" for c in changes)
