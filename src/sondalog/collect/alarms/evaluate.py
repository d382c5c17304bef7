"""The alarm core (issue 21): observations in, typed transitions out; sans-I/O.

::

    alarms = Alarms(plan, records=store.load_states())
    alarms.watch_source("station-1", interval=60, last_contact=t0, now=now)
    out = alarms.reading(Sample("station-1", "000123", 3, 41.2, t, name="Air"))
    out += alarms.ingest("station-1", readings)     # the collector's stored readings, fast
    out += alarms.contact(Contact("station-1", ok=True, time=now))
    out += alarms.advance(now)                      # no-contact and sink timers
    wake = alarms.next_deadline()                   # when to call advance again
    store.save_states(alarms.changed())             # with the outbox rows, one transaction
    # or store.save_changes(alarms.changes()): the same, cheaper (after every chunk)

No clock is read here: every time comes in with the observation (a reading's own time, so a
download of old rows raises and clears with those times) or as ``now``. The state of every
alarm is exported with :meth:`Alarms.changed` / :meth:`Alarms.export` and given back to the
constructor, so a restart neither forgets an alarm nor raises it again: readings older than
an alarm's last one are ignored, and a raise is named by its own time
(:func:`~.events.event_key`), the same however often it is computed.
"""

from __future__ import annotations

from collections.abc import Iterable
from fnmatch import fnmatchcase
from typing import TYPE_CHECKING

from .describe import cleared_text, raised_text
from .events import (
    Acknowledged,
    AlarmRecord,
    Cleared,
    Condition,
    Contact,
    Health,
    Raised,
    Sample,
    StateChanges,
    Transition,
    alarm_id,
    event_key,
)
from .ingest import Ingest
from .kinds import (
    READINGS,
    Track,
    Verdict,
    level,
    refusing,
)
from .progress import fits, logger_of, pack
from .rules import AlarmPlan, Rule

if TYPE_CHECKING:
    from sondalog.collect.model import Reading

#: ``no_contact`` without ``after``: this many of the source's intervals.
INTERVALS = 3


class Alarms:
    """Every alarm of ``plan``; ``records``: the state a previous run exported (records of
    rules no longer in the file are forgotten)."""

    def __init__(self, plan: AlarmPlan, records: Iterable[AlarmRecord] = ()) -> None:
        self.plan = plan
        self._rules = {rule.name: rule for rule in plan.rules}
        self._tracks: dict[tuple[str, str], Track] = {}
        self._by_id: dict[str, Track] = {}
        #: Alarms changed since the last :meth:`changes`: in full (state, times, new ones),
        #: and in their rule's progress only (count, last value, last reading's time).
        self._dirty: dict[str, Track] = {}
        self._progress: dict[str, Track] = {}
        #: The reading rules' alarms of each logger, and each one's logger: their progress
        #: is saved one row per logger (:mod:`.progress`).
        self._loggers: dict[str, dict[str, Track]] = {}
        self._logger_of: dict[str, str] = {}
        #: Timers (no contact, sink down): the alarm and the seconds from its ``ref`` to the
        #: raise (not kept: it comes from the file and the source's interval).
        self._timers: dict[str, tuple[Track, float]] = {}
        self._reading_rules = plan.of_kind(*READINGS)
        self._matches: dict[tuple[str, str, int, str | None], list[tuple[Rule, Track]]] = {}
        self._ingest = Ingest(
            self._reading_rules, self._tracks, self._reading_track, self._apply, self._progress
        )
        for record in records:
            rule = self._rules.get(record.rule)
            if rule is None or rule.kind != record.kind:
                continue  # the rule left the file (or changed kind): its alarms go too
            track = self._add(record.copy())
            if rule.watch == "sink" and track.ref is not None:
                self._timers[track.alarm] = (track, rule.after or 0.0)

    # -- tracks ---------------------------------------------------------------------------

    def _add(self, track: Track) -> Track:
        self._tracks[(track.rule, track.subject)] = track
        self._by_id[track.alarm] = track
        if track.kind in READINGS and fits(track.alarm):
            logger = self._logger_of[track.alarm] = logger_of(track.subject)
            self._loggers.setdefault(logger, {})[track.alarm] = track
        return track

    def _track(self, rule: Rule, subject: str) -> Track:
        track = self._tracks.get((rule.name, subject))
        if track is None:
            track = self._add(Track(alarm_id(rule.name, subject), rule.name, rule.kind, subject))
        self._dirty[track.alarm] = track
        return track

    def _reading_track(self, rule: Rule, subject: str) -> Track:
        """A reading rule's alarm, marked changed only if it is new (a reading it takes
        marks its progress; an alarm back from the store is not written again for nothing)."""
        track = self._tracks.get((rule.name, subject))
        if track is None:
            track = self._add(Track(alarm_id(rule.name, subject), rule.name, rule.kind, subject))
            self._dirty[track.alarm] = track
        return track

    def _apply(
        self,
        rule: Rule,
        track: Track,
        verdict: Verdict,
        time: float,
        value: float | None,
        extra: str = "",
    ) -> list[Transition]:
        if verdict == "raise" and not track.active:
            self._dirty[track.alarm] = track
            track.state, track.since, track.raised_at = "raised", time, time
            track.acked_at = track.cleared_at = None
            track.event = event_key(track.alarm, time)
            track.value = value
            track.text = raised_text(rule, track.subject, value, extra)
            return [self._transition(Raised, track, time, value, track.text)]
        if verdict == "clear" and track.active:
            self._dirty[track.alarm] = track
            track.state, track.since, track.cleared_at = "cleared", time, time
            text = cleared_text(rule, track.subject, value)
            return [self._transition(Cleared, track, time, value, text)]
        return []

    @staticmethod
    def _transition(
        kind: type[Raised] | type[Cleared],
        track: Track,
        time: float,
        value: float | None,
        text: str,
    ) -> Transition:
        event = track.event or ""
        if kind is Cleared:
            return Cleared(
                track.alarm,
                event,
                track.rule,
                track.kind,
                track.subject,
                time,
                value,
                text,
                raised_at=track.raised_at or time,
            )
        return Raised(track.alarm, event, track.rule, track.kind, track.subject, time, value, text)

    # -- observations ---------------------------------------------------------------------

    def reading(self, sample: Sample) -> list[Transition]:
        """One reading (in the record's order per channel; older ones are ignored)."""
        if sample.value is None:
            return []
        key = (sample.source, sample.logger, sample.channel, sample.name)
        pairs = self._matches.get(key)
        if pairs is None:
            subject = f"{sample.logger}/{sample.channel}"
            pairs = [
                (r, self._reading_track(r, subject))
                for r in self._reading_rules
                if r.matches(sample.source, sample.logger)
                and r.matches_channel(sample.channel, sample.name)
            ]
            self._matches[key] = pairs
        out: list[Transition] = []
        for rule, track in pairs:
            if not track.newer(sample.time, sample.counter):
                continue
            self._progress[track.alarm] = track
            last = track.last_value
            verdict = READINGS[rule.kind](rule, track, sample.value)
            if verdict is not None:
                extra = f"from {last:g}" if rule.kind == "step" and last is not None else ""
                out += self._apply(rule, track, verdict, sample.time, sample.value, extra)
        return out

    def readings(self, samples: Iterable[Sample]) -> list[Transition]:
        out: list[Transition] = []
        for sample in samples:
            out += self.reading(sample)
        return out

    def ingest(self, source: str, readings: Iterable[Reading]) -> list[Transition]:
        """The collector's readings of ``source`` as they are stored: the same answer as
        ``readings(Sample.of(source, r) for r in readings)``, made fast for the ingest path
        (:mod:`.ingest`)."""
        return self._ingest.run(source, readings)

    def watch_source(
        self,
        source: str,
        interval: float,
        *,
        now: float,
        last_contact: float | None = None,
        logger: str | None = None,
    ) -> None:
        """Watch ``source`` for ``no_contact`` (``interval``: its contact interval, or a
        message source's message period; ``logger``: its serial number if known, for rules that
        name loggers); the timer starts at ``last_contact`` (from the
        store) or ``now``. An alarm restored from the store keeps its own timer."""
        for rule in self.plan.of_kind("no_contact"):
            if rule.matches(source, logger):
                track = self._track(rule, source)
                after = rule.after if rule.after is not None else INTERVALS * interval
                if track.ref is None:
                    track.ref = last_contact if last_contact is not None else now
                self._timers[track.alarm] = (track, after)

    def contact(self, contact: Contact) -> list[Transition]:
        """A contact of a source: a good one restarts its no-contact timer and clears it."""
        out: list[Transition] = []
        for rule in self.plan.of_kind("no_contact"):
            track = self._tracks.get((rule.name, contact.source))
            if track is None or not contact.ok or not contact.heard:
                continue
            if track.ref is not None and contact.time < track.ref:
                continue  # an old contact reported late
            self._dirty[track.alarm] = track
            track.ref = contact.time
            out += self._apply(rule, track, "clear", contact.time, None)
        for rule in self.plan.of_kind("collector"):
            if rule.watch == "source" and rule.matches(contact.source, None):
                track = self._track(rule, contact.source)
                if not track.newer(contact.time):
                    continue
                verdict = refusing(rule, track, contact.ok)
                extra = f": {contact.error}" if contact.error else ""
                out += self._apply(rule, track, verdict, contact.time, track.count, extra)
        return out

    def health(self, sample: Health) -> list[Transition]:
        """A logger's health: each ``health`` rule looks at its ``measure``."""
        out: list[Transition] = []
        subject = sample.logger or sample.source
        for rule in self.plan.of_kind("health"):
            value = sample.measure(rule.measure)
            if value is None or not rule.matches(sample.source, sample.logger):
                continue
            track = self._track(rule, subject)
            if track.newer(sample.time):
                out += self._apply(rule, track, level(rule, track, value), sample.time, value)
        return out

    def condition(self, condition: Condition) -> list[Transition]:
        """The collector's own condition (a sink down or up, its buffer's size)."""
        out: list[Transition] = []
        for rule in self.plan.of_kind("collector"):
            if rule.watch != condition.watch or not fnmatchcase(condition.subject, rule.sink):
                continue
            track = self._track(rule, condition.subject)
            if not track.newer(condition.time):
                continue
            if rule.watch == "buffer":
                verdict = level(rule, track, condition.value)
                out += self._apply(rule, track, verdict, condition.time, condition.value)
            elif condition.value > 0:  # the sink is down
                if track.ref is None:
                    track.ref = condition.time
                self._timers[track.alarm] = (track, rule.after or 0.0)
                out += self._expire(track, rule.after or 0.0, condition.time)
            else:
                track.ref = None
                self._timers.pop(track.alarm, None)
                out += self._apply(rule, track, "clear", condition.time, 0.0)
        return out

    # -- timers ---------------------------------------------------------------------------

    def advance(self, now: float) -> list[Transition]:
        """Raise every timer (no contact, sink down) that ran out by ``now``, at the time
        it ran out."""
        out: list[Transition] = []
        for track, after in list(self._timers.values()):
            out += self._expire(track, after, now)
        return out

    def _expire(self, track: Track, after: float, now: float) -> list[Transition]:
        if track.active or track.ref is None or track.ref + after > now:
            return []
        rule = self._rules[track.rule]
        self._dirty[track.alarm] = track
        due = track.ref + after
        return self._apply(rule, track, "raise", due, round(due - track.ref, 3))

    def next_deadline(self) -> float | None:
        """When :meth:`advance` has something to do next (``None``: nothing is pending)."""
        due = [
            t.ref + after
            for t, after in self._timers.values()
            if not t.active and t.ref is not None
        ]
        return min(due, default=None)

    # -- people ---------------------------------------------------------------------------

    def acknowledge(self, alarm: str, now: float, by: str = "") -> Acknowledged | None:
        """Acknowledge the raised alarm ``alarm`` (its id): it stays on until it clears, but
        is no longer repeated. ``None`` if it is not raised (unknown, already acknowledged
        or cleared)."""
        track = self._by_id.get(alarm)
        if track is None or track.state != "raised":
            return None
        track.state, track.since, track.acked_at = "acknowledged", now, now
        self._dirty[track.alarm] = track
        return Acknowledged(
            track.alarm,
            track.event or "",
            track.rule,
            track.kind,
            track.subject,
            now,
            track.value,
            f"{track.text} (acknowledged{' by ' + by if by else ''})",
            by=by,
        )

    # -- state ----------------------------------------------------------------------------

    def get(self, alarm: str) -> AlarmRecord | None:
        track = self._by_id.get(alarm)
        return track.copy() if track is not None else None

    def active(self) -> list[AlarmRecord]:
        """The alarms that are on (raised or acknowledged), oldest first."""
        on = [t.copy() for t in self._tracks.values() if t.active]
        return sorted(on, key=lambda r: (r.raised_at or 0.0, r.alarm))

    def export(self) -> list[AlarmRecord]:
        """Every alarm's state (for the store)."""
        return [t.copy() for t in self._tracks.values()]

    def changed(self) -> list[AlarmRecord]:
        """The alarms changed since the last call (what the store has to write)."""
        out = [t.copy() for t in self._dirty.values()]
        out += [t.copy() for a, t in self._progress.items() if a not in self._dirty]
        self._dirty.clear()
        self._progress.clear()
        return out

    def changes(self) -> StateChanges:
        """What :meth:`changed` says, as the rows :meth:`AlarmStore.save_changes` writes
        (cheaper, for the ingest path): an alarm whose only change is its rule's progress
        (count, last value, last reading's time: every reading changes them) has only that
        written: a reading rule's in its logger's row of ``alarm_progress`` (one row for
        all of them, :mod:`.progress`), any other's in its own row's progress columns."""
        dirty, progress, logger_of = self._dirty, self._progress, self._logger_of
        loggers: dict[str, None] = {}
        counters = []
        for alarm, track in progress.items():
            logger = logger_of.get(alarm)
            if logger is not None:
                loggers[logger] = None
            elif alarm not in dirty:
                counters.append(track.row())
        out = StateChanges(
            [t.row() for t in dirty.values()],
            counters,
            [(logger, pack(self._loggers[logger])) for logger in sorted(loggers)],
        )
        dirty.clear()
        progress.clear()
        return out
