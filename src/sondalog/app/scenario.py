"""A site's scenario (issue 23, docs/control.md "Scenarios"): ``[[scenario]]`` entries and
the pure schedule that says which of them are due.

Each entry is one action of the control vocabulary (:mod:`sondalog.app.control_actions`:
``set``, ``fault``, ``clear``, ``restart``, ``snapshot``, ``restore``) on a ``device``
(default ``logger``), with the action's own keys, and **when**: ``at`` a module time (the
logger's clock, §6.3: ``"03:00"`` is the first 03:00 at or after the start, ``"2007-03-02
03:00"`` that moment) or ``after`` a duration from the start (seconds, or ``"2h30m"``)::

    [[scenario]]
    at = "03:00"
    action = "fault"
    kind = "disconnected"
    input = "analog:16"

Everything is read through :class:`sondalog.config.Table` when the file is loaded, so a bad
entry is refused with its file, line and field before anything is served. :class:`Schedule`
is the sans-I/O core: the steps with their due times (site clock seconds), and
:meth:`Schedule.pop_due` hands out each exactly once, in time order (file order for equal
times); :mod:`sondalog.app.scenario_run` drives it on a running site.
"""

from __future__ import annotations

import re
from bisect import insort
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime, time, timedelta
from typing import Generic, TypeVar

from sondalog.app.control_actions import MAX_SECONDS, Action, parse_action, parse_duration
from sondalog.config import Table

#: The actions a scenario may take (time is the control API's or ``--speed``'s business).
SCENARIO_ACTIONS = ("set", "fault", "clear", "restart", "snapshot", "restore")
#: The most entries a scenario may have.
MAX_STEPS = 10_000
_KEYS = ("action", "device", "at", "after")
_AT_WHAT = 'a module time "HH:MM[:SS]" or "YYYY-MM-DD HH:MM[:SS]"'

T = TypeVar("T")


@dataclass(frozen=True)
class ScenarioStep:
    """One ``[[scenario]]`` entry: what it does and when (exactly one of ``at``, ``after``)."""

    index: int
    entry: Table  # the entry itself: its file and line, for errors and announcements
    action: Action
    device: str
    at: datetime | time | None = None  # module time: a moment, or the next time of day
    after: float | None = None  # seconds after the start
    clock: str | None = None  # the logger whose module time ``at`` is

    @property
    def where(self) -> str:
        """``site.toml:12`` (the line of the entry's action)."""
        name = self.entry.file.name if self.entry.file is not None else "<scenario>"
        line = self.entry.line("action") or self.entry.line()
        return f"{name}:{line}" if line else name

    def describe(self) -> str:
        """``fault disconnected on logger analog:16`` (for the announcement)."""
        entry = self.entry
        said = [str(entry.raw("action")), *([str(entry.raw("kind"))] if "kind" in entry else [])]
        said += ["on", self.device, *(str(entry.raw(k)) for k in ("input", "name") if k in entry)]
        return " ".join(said + ([f"= {entry.raw('value')}"] if "value" in entry else []))


def parse_scenario(root: Table, devices: Sequence[str]) -> list[ScenarioStep]:
    """The ``[[scenario]]`` entries of ``root`` for a site with ``devices`` (``logger``,
    ``loggers.SERIAL``, ``bus``, ``gsm``, ``mail``); raises
    :class:`~sondalog.config.ConfigError`."""
    entries = root.tables("scenario")
    if len(entries) > MAX_STEPS:
        raise root.fail("scenario", f"at most {MAX_STEPS} entries")
    loggers = [d for d in devices if d == "logger" or d.startswith("loggers.")]
    return [_step(i, entry, devices, loggers) for i, entry in enumerate(entries)]


def _step(index: int, entry: Table, devices: Sequence[str], loggers: list[str]) -> ScenarioStep:
    action = entry.text("action", choices=SCENARIO_ACTIONS)
    device = entry.text("device", "logger", what="a device: logger, loggers.SERIAL, bus, gsm, mail")
    if device not in devices:
        shown = ", ".join(devices[:8]) + (" ..." if len(devices) > 8 else "")
        raise entry.fail("device", f"the site has no device {device!r} (it has {shown})")
    parsed = parse_action(action, device, entry, _KEYS)
    if ("at" in entry) == ("after" in entry):
        raise entry.fail("at", "give exactly one of at (a module time) or after (a duration)")
    if "after" in entry:
        after = (
            entry.convert("after", parse_duration)
            if entry.is_text("after")
            else entry.number("after", lo=0, hi=MAX_SECONDS, what="seconds >= 0, or like 2h30m")
        )
        return ScenarioStep(index, entry, parsed, device, after=after)
    clock = device if device in loggers else ("logger" if "logger" in loggers else None)
    clock = clock or (loggers[0] if loggers else None)
    if clock is None:
        raise entry.fail("at", "the site has no logger whose module time it could be: use after")
    return ScenarioStep(index, entry, parsed, device, at=_at(entry), clock=clock)


def _at(entry: Table) -> datetime | time:
    raw = entry.raw("at")
    if isinstance(raw, datetime | time):  # a TOML local time or date-time
        if raw.tzinfo is not None:
            raise entry.fail("at", "a module time has no time zone (the logger's clock has none)")
        return raw
    if not entry.is_text("at"):
        raise entry.fail("at", f"must be {_AT_WHAT}, not {raw!r}")
    return entry.convert("at", parse_at)


def parse_at(text: str) -> datetime | time:
    """``03:00``, ``3:00:30`` (a time of day) or ``2007-03-02 03:00[:SS]`` (``T`` too)."""
    value = text.strip()
    try:
        if re.fullmatch(r"\d{1,2}:\d{2}(:\d{2})?", value):
            return time.fromisoformat(value if value.index(":") == 2 else "0" + value)
        if re.fullmatch(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2})?", value):
            return datetime.fromisoformat(value.replace(" ", "T"))
    except ValueError:
        pass
    raise ValueError(f"must be {_AT_WHAT}, not {text!r}")


def resolve_at(at: datetime | time, module_now: datetime, now: float) -> float:
    """The site clock's time (``now`` is the site clock when the logger's module time is
    ``module_now``) at which module time ``at`` comes: a time of day at or after it."""
    if isinstance(at, time):
        moment = datetime.combine(module_now.date(), at)
        if moment < module_now:
            moment += timedelta(days=1)
    else:
        moment = at
    return now + (moment - module_now).total_seconds()


class Schedule(Generic[T]):
    """Steps with due times; :meth:`pop_due` gives each once, in (time, given) order."""

    def __init__(self, steps: Iterable[tuple[float, T]] = ()) -> None:
        self._due: list[tuple[float, int, T]] = []
        self._count = 0
        for due, step in steps:
            self.add(due, step)

    def add(self, due: float, step: T) -> None:
        insort(self._due, (due, self._count, step), key=lambda item: (item[0], item[1]))
        self._count += 1

    def __len__(self) -> int:
        return len(self._due)

    def next_due(self) -> float | None:
        """When the next step is due (``None``: nothing left)."""
        return self._due[0][0] if self._due else None

    def pop_due(self, now: float) -> list[T]:
        """Every step due at or before ``now``, in order; they are not given again."""
        count = 0
        while count < len(self._due) and self._due[count][0] <= now:
            count += 1
        taken, self._due = self._due[:count], self._due[count:]
        return [step for _, _, step in taken]
