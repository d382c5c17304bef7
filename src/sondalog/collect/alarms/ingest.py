"""The collector's readings through the reading rules, fast (issue 21: 10 rules on every
channel of 1,000 loggers cost at most a tenth of the ingest).

:meth:`~.evaluate.Alarms.ingest` hands each chunk of stored readings to :class:`Ingest`. Its
answer is exactly that of one :class:`~.events.Sample` a reading through
:meth:`~.evaluate.Alarms.reading`: the same transitions in the same order, the same alarms
changed, the same states (tests/collect/alarms/test_alarm_ingest.py checks it on random rules
and readings). What makes it fast:

- each (source, logger, channel, name) is a :class:`Channel`: its matching rules (matched
  once for every logger they match alike), each with its alarm; a rule is compiled into
  one function (:func:`~.kinds.compile_check`) for all its alarms, once, so a restart
  compiles the rules, not every (logger, channel); a row's time is computed once for its
  channels;
- a channel whose rules are all thresholds (``for`` >= 1) and whose alarms are all off
  with no reading counted towards a raise is *quiet*: a reading on the good side of every
  limit changes nothing but each alarm's last reading, and that last reading is the newest
  one whatever the order. So a quiet reading only moves the channel's newest (time,
  counter); the alarms take it (:meth:`Channel.settle`) before the channel's next reading
  that is not quiet, and when the chunk ends. Every other reading goes through the closures
  in order, and the channel is checked again for quiet after it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from math import inf
from typing import TYPE_CHECKING

from .events import Transition, reading_time
from .kinds import Apply, Check, Track, compile_check
from .rules import Rule

if TYPE_CHECKING:
    from sondalog.collect.model import Reading


@dataclass(slots=True, eq=False)
class Channel:
    """One channel's compiled rules, its alarms, and the quiet readings not settled yet."""

    name: str | None
    #: The rules' alarms of this channel, and each with its rule compiled (the compiled
    #: checks are shared by every channel with the same rules).
    tracks: tuple[Track, ...]
    pairs: tuple[tuple[Check, Track], ...]
    #: Every rule a threshold with ``for`` >= 1 (and no alarm shared with another channel).
    thresholds: bool
    #: Quiet readings are within [lo, hi]: at or above every ``below``, at or below every
    #: ``above`` limit.
    lo: float = -inf
    hi: float = inf
    quiet: bool = False
    #: The :class:`Ingest` call ``quiet`` was checked in.
    epoch: int = -1
    #: The newest quiet reading not settled yet (``None``: none).
    newest: float | None = None
    newest_counter: int = 0

    def check_quiet(self) -> None:
        if self.thresholds:
            for t in self.tracks:  # a loop, not all(): no generator made each time
                if t.count != 0 or t.state == "raised" or t.state == "acknowledged":
                    break
            else:
                self.quiet = True
                return
        self.quiet = False

    def settle(self, progress: dict[str, Track]) -> None:
        """Every alarm takes the newest quiet reading if it is newer than its last one."""
        t, c = self.newest, self.newest_counter
        if t is None:
            return
        self.newest = None
        for track in self.tracks:
            last = track.last_time
            if last is None or t > last or (t == last and c > track.last_counter):
                track.last_time, track.last_counter = t, c
                track.count = 0
                progress[track.alarm] = track


@dataclass(frozen=True, slots=True)
class _Rules:
    """The rules of a channel, and what makes its readings quiet (:class:`Channel`)."""

    rules: tuple[Rule, ...]
    thresholds: bool
    lo: float
    hi: float
    #: The rules' names (an alarm is found by (rule name, subject)).
    names: tuple[str, ...]
    #: The rules compiled (:func:`~.kinds.compile_check`).
    checks: tuple[Check, ...]

    @classmethod
    def of(cls, rules: tuple[Rule, ...], checks: tuple[Check, ...]) -> _Rules:
        return cls(
            rules,
            names=tuple(r.name for r in rules),
            checks=checks,
            thresholds=bool(rules) and all(r.kind == "threshold" and r.count >= 1 for r in rules),
            lo=max((r.limit for r in rules if r.direction == "below"), default=-inf),
            hi=min((r.limit for r in rules if r.direction == "above"), default=inf),
        )


@dataclass(slots=True)
class _RuleSet:
    """The reading rules that watch some loggers, and those of each (channel, name)."""

    rules: tuple[Rule, ...]
    by_channel: dict[tuple[int, str | None], _Rules] = field(default_factory=dict)


class Ingest:
    """The fast path of one :class:`~.evaluate.Alarms`: ``tracks`` are its alarms by (rule
    name, subject), ``track(rule, subject)`` gives one (new ones made and marked changed),
    ``apply`` makes a verdict a transition, ``progress`` is where an alarm whose rule's
    progress changed is marked."""

    def __init__(
        self,
        rules: list[Rule],
        tracks: dict[tuple[str, str], Track],
        track: Callable[[Rule, str], Track],
        apply: Apply,
        progress: dict[str, Track],
    ) -> None:
        self._rules = rules
        self._tracks = tracks
        self._track = track
        self._apply = apply
        self._progress = progress
        self._epoch = 0
        #: (source, logger) -> channel number -> the channel of the name seen last.
        self._loggers: dict[tuple[str, str], dict[int, Channel]] = {}
        self._channels: dict[tuple[str, str, int, str | None], Channel] = {}
        #: ``LOGGER/CHANNEL`` (the alarms' subject) -> its first channel: the alarms of two
        #: channels of one subject (renamed, or two sources) are shared, neither is quiet.
        self._subjects: dict[str, Channel] = {}
        self._logger_rules: dict[tuple[str, str], _RuleSet] = {}
        self._rule_sets: dict[tuple[int, ...], _RuleSet] = {}
        self._channel_names: dict[tuple[str, str | None], bool] = {}
        #: Each rule compiled (by name), once for all its alarms.
        self._checks: dict[str, Check] = {}

    def run(self, source: str, readings: Iterable[Reading]) -> list[Transition]:
        """The transitions of ``readings`` (of ``source``), in order."""
        out: list[Transition] = []
        self._epoch += 1
        epoch = self._epoch
        progress = self._progress
        seen: list[Channel] = []
        logger: object = None
        channels: dict[int, Channel] = {}
        stamp: object = None
        utc: object = None
        t = 0.0
        try:
            for r in readings:
                v = r.value
                if v is None:
                    continue
                if r.logger is not logger:  # a chunk is mostly one logger's
                    logger = r.logger
                    channels = self._loggers.setdefault((source, r.logger), {})
                name = r.name
                ch = channels.get(r.channel)
                if ch is None or (ch.name is not name and ch.name != name):
                    ch = channels[r.channel] = self._channel(source, r.logger, r.channel, name)
                if not ch.tracks:
                    continue
                if r.time is not stamp or r.utc is not utc:
                    stamp, utc = r.time, r.utc
                    t = reading_time(r)
                c = r.counter
                if ch.epoch != epoch:  # the alarms may have changed since the last chunk
                    ch.epoch = epoch
                    ch.check_quiet()
                    seen.append(ch)
                if ch.quiet and ch.lo <= v <= ch.hi:
                    newest = ch.newest
                    if newest is None or t > newest or (t == newest and c > ch.newest_counter):
                        ch.newest, ch.newest_counter = t, c
                    continue
                if ch.newest is not None:
                    ch.settle(progress)
                for check, track in ch.pairs:
                    got = check(track, t, c, v)
                    if got:
                        out += got
                if ch.thresholds:
                    ch.check_quiet()
        finally:
            for ch in seen:
                ch.settle(progress)
        return out

    def _channel(self, source: str, logger: str, channel: int, name: str | None) -> Channel:
        """The channel's state, made when it is first read (after a restart: from the
        alarms the store gave back, found by name: no hash computed)."""
        key = (source, logger, channel, name)
        found = self._channels.get(key)
        if found is not None:
            return found
        rule_set = self._logger_rules.get((source, logger))
        if rule_set is None:
            rule_set = self._rule_set(source, logger)
        rules = rule_set.by_channel.get((channel, name))
        if rules is None:
            rules = self._rules_of(rule_set, channel, name)
        subject = f"{logger}/{channel}"
        known, make = self._tracks.get, self._track
        pairs = zip(rules.rules, rules.names, strict=True)
        tracks = tuple([known((n, subject)) or make(r, subject) for r, n in pairs])  # make: new
        found = Channel(
            name,
            tracks,
            tuple(zip(rules.checks, tracks, strict=True)),
            rules.thresholds,
            rules.lo,
            rules.hi,
        )
        self._channels[key] = found
        other = self._subjects.setdefault(subject, found)
        if other is not found:  # renamed, or read by two sources: the alarms are shared
            for ch in (other, found):
                ch.settle(self._progress)
                ch.thresholds = ch.quiet = False
        return found

    def _compile(self, rule: Rule) -> Check:
        check = self._checks.get(rule.name)
        if check is None:
            check = self._checks[rule.name] = compile_check(rule, self._progress, self._apply)
        return check

    def _rule_set(self, source: str, logger: str) -> _RuleSet:
        """The rules that watch ``logger`` of ``source`` (one set for all loggers alike)."""
        which = tuple(i for i, r in enumerate(self._rules) if r.matches(source, logger))
        found = self._rule_sets.get(which)
        if found is None:
            found = self._rule_sets[which] = _RuleSet(tuple(self._rules[i] for i in which))
        self._logger_rules[(source, logger)] = found
        return found

    def _rules_of(self, rule_set: _RuleSet, channel: int, name: str | None) -> _Rules:
        """The rules of ``rule_set`` on (``channel``, ``name``), matched and compiled."""
        matched = tuple(r for r in rule_set.rules if self._channel_matches(r, channel, name))
        rules = rule_set.by_channel[(channel, name)] = _Rules.of(
            matched, tuple(self._compile(r) for r in matched)
        )
        return rules

    def _channel_matches(self, rule: Rule, channel: int, name: str | None) -> bool:
        if rule.channel is not None or rule.channel_name is None or name is None:
            return rule.matches_channel(channel, name)
        known = self._channel_names.get((rule.channel_name, name))
        if known is None:
            known = fnmatchcase(name, rule.channel_name)
            self._channel_names[(rule.channel_name, name)] = known
        return known
