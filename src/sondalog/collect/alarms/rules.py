"""What the collector's file says about alarms: rules and destinations (issue 21).

A :class:`Rule` is one ``[[alarm]]`` table, a :class:`Notify` one ``[[notify]]`` table; an
:class:`AlarmPlan` holds both, checked (every ``notify`` name exists, rule names unique).
They are plain data: :mod:`.parse` makes them from the file, :mod:`.evaluate` and
:mod:`.policy` use them. Durations are seconds; times are seconds since the epoch (UTC).
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field
from datetime import datetime, time, timedelta, tzinfo
from typing import Any, Generic, Literal, TypeVar

#: The kinds of ``[[alarm]]`` (docs/alarms.md has one example of each).
RULE_KINDS = ("no_contact", "threshold", "stuck", "step", "health", "collector")
#: What a ``health`` rule watches, and the direction that is bad for it.
HEALTH_MEASURES: dict[str, Literal["above", "below"]] = {
    "supply": "below",  # volts
    "memory": "above",  # record memory fill ratio 0..1 (``record status``)
    "clock": "above",  # |logger clock - collector clock| in seconds
    "signal": "below",  # GSM signal
    "credit": "below",  # SIM credit
    "gaps": "above",  # rows a download found lost from the cyclic record
    "drift": "above",  # settings that differ from the source's expect file (config_watch.py)
}
#: What a ``collector`` rule watches.
COLLECTOR_WATCHES = ("sink", "buffer", "source")
#: A destination kind's own settings (:mod:`.senders`: each kind parses its own).
S = TypeVar("S")


@dataclass(frozen=True, slots=True)
class Rule:
    """One ``[[alarm]]``; the fields a kind does not use keep their defaults."""

    name: str
    kind: str
    notify: tuple[str, ...] = ()
    #: Globs (``F*``) on the logger's serial number and the source's name.
    logger: str = "*"
    source: str = "*"
    #: ``collector`` rules on a sink (``sink``, ``buffer``): a glob on the sink's name.
    sink: str = "*"
    #: A channel by number or by name (a glob); neither: every channel.
    channel: int | None = None
    channel_name: str | None = None
    #: ``threshold``/``health``/``collector buffer``: bad above or below ``limit``.
    direction: Literal["above", "below"] = "above"
    limit: float = 0.0
    #: The value on the good side of which the alarm clears (hysteresis).
    clear: float = 0.0
    #: Consecutive observations to raise (threshold, stuck, health, collector source) or,
    #: for ``step``, calm readings to clear.
    count: int = 1
    #: Consecutive good observations to clear (threshold and health: ``count``; others 1).
    clear_count: int = 1
    #: ``no_contact``: seconds without a good contact (``None``: 3 intervals of the source);
    #: ``collector sink``: seconds down before it is raised.
    after: float | None = None
    #: ``step``: the largest jump between two readings that is not an alarm.
    step: float = 0.0
    #: ``stuck``: values closer than this count as the same.
    tolerance: float = 0.0
    measure: str = ""  # health
    watch: str = ""  # collector
    #: The line of the rule's table in the file (for messages), if known.
    line: int | None = None

    def matches(self, source: str, logger: str | None) -> bool:
        """Whether the rule watches ``source`` / ``logger`` (globs, case-sensitive)."""
        if self.source != "*" and not fnmatch.fnmatchcase(source, self.source):
            return False
        if self.logger == "*":
            return True
        return logger is not None and fnmatch.fnmatchcase(logger, self.logger)

    def matches_channel(self, channel: int, name: str | None) -> bool:
        if self.channel is not None:
            return channel == self.channel
        if self.channel_name is not None:
            return name is not None and fnmatch.fnmatchcase(name, self.channel_name)
        return True

    def bad(self, value: float) -> bool:
        return value > self.limit if self.direction == "above" else value < self.limit

    def good(self, value: float) -> bool:
        return value <= self.clear if self.direction == "above" else value >= self.clear


@dataclass(frozen=True, slots=True)
class Rate:
    """At most ``count`` messages to a destination per window of ``per`` seconds; the rest
    of the window goes out as one summary when the window ends."""

    count: int
    per: float

    def window(self, now: float) -> int:
        return int(now // self.per)

    def start(self, now: float) -> float:
        return self.window(now) * self.per

    def end(self, now: float) -> float:
        return (self.window(now) + 1) * self.per


@dataclass(frozen=True, slots=True)
class Quiet:
    """A daily window of local time (``22:00-06:00`` spans midnight) in which messages to a
    destination are held until the window ends (or dropped, ``quiet_mode = "drop"``)."""

    start: time
    end: time

    def contains(self, when: datetime) -> bool:
        now = when.time().replace(tzinfo=None)
        if self.start <= self.end:
            return self.start <= now < self.end
        return now >= self.start or now < self.end

    def __str__(self) -> str:
        return f"{self.start:%H:%M}-{self.end:%H:%M}"


@dataclass(frozen=True, slots=True)
class Notify(Generic[S]):
    """One ``[[notify]]`` destination: what every kind has, and ``settings``, what only its
    kind uses, typed by the kind (``send_email.EmailSettings``...: the ``parse`` registered
    with its sender, :func:`~.senders.register_sender`), already checked."""

    name: str
    kind: str
    settings: S
    #: Re-notify a raised, unacknowledged alarm every this many seconds (``None``: never).
    repeat: float | None = None
    quiet: tuple[Quiet, ...] = ()
    quiet_mode: Literal["hold", "drop"] = "hold"
    rate: Rate | None = None
    #: Give up after this many failed attempts (``None``: retry for ever).
    retries: int | None = None
    #: First retry after this many seconds, doubling up to ``backoff_max``.
    backoff: float = 10.0
    backoff_max: float = 3600.0
    zone: tzinfo | None = None
    line: int | None = None

    def quiet_until(self, now: float, zone: tzinfo) -> float | None:
        """The end of the quiet window ``now`` is in (epoch seconds), or ``None``."""
        when = datetime.fromtimestamp(now, self.zone or zone)
        for window in self.quiet:
            if window.contains(when):
                end = datetime.combine(when.date(), window.end, when.tzinfo)
                if end <= when:
                    end = datetime.combine(when.date() + timedelta(days=1), window.end, when.tzinfo)
                return end.timestamp()
        return None

    def retry_delay(self, attempts: int) -> float:
        """Seconds before the next try after ``attempts`` failed ones."""
        return min(self.backoff * 2.0 ** max(attempts - 1, 0), self.backoff_max)


@dataclass(frozen=True, slots=True)
class AlarmPlan:
    """Every rule and destination of a collector's file."""

    rules: tuple[Rule, ...] = ()
    notify: dict[str, Notify[Any]] = field(default_factory=dict)

    def rule(self, name: str) -> Rule | None:
        for rule in self.rules:
            if rule.name == name:
                return rule
        return None

    def of_kind(self, *kinds: str) -> list[Rule]:
        return [r for r in self.rules if r.kind in kinds]
