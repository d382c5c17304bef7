"""How each kind of rule turns one observation into raise, clear or nothing (issue 21).

Pure functions over a :class:`Track` (an alarm's record, changed in place): the counting
that makes a rule wait for ``for`` observations and its clear condition, so that nothing flaps:

- levels (``threshold``, ``health``, ``collector buffer``): raised after ``count`` bad
  observations in a row, cleared after ``clear_count`` in a row on the good side of
  ``clear`` (hysteresis: between ``clear`` and the limit nothing changes);
- ``stuck``: raised when ``count`` readings in a row are the same (within ``tolerance``),
  cleared by the first different one;
- ``step``: raised by a jump larger than ``step`` between two readings, cleared after
  ``count`` calm readings;
- ``collector source``: raised after ``count`` failed contacts in a row, cleared by a good one.

``no_contact`` and ``collector sink`` are timers, handled by :mod:`.evaluate`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

from .events import AlarmRecord, Transition
from .rules import Rule

Verdict = Literal["raise", "clear"] | None
#: An alarm's mutable state, as the core keeps it: its record (:class:`AlarmRecord`),
#: changed in place.
Track = AlarmRecord


def level(rule: Rule, track: Track, value: float) -> Verdict:
    """``threshold``, ``health``, ``collector buffer``."""
    if not track.active:
        track.count = track.count + 1 if rule.bad(value) else 0
        if track.count >= rule.count:
            track.count = 0
            return "raise"
    else:
        track.count = track.count + 1 if rule.good(value) else 0
        if track.count >= rule.clear_count:
            track.count = 0
            return "clear"
    return None


def stuck(rule: Rule, track: Track, value: float) -> Verdict:
    last = track.last_value
    same = last is not None and abs(value - last) <= rule.tolerance
    track.count = track.count + 1 if same else 1
    if not same:
        track.last_value = value  # compare with the run's first value: no slow creep
    if not track.active and track.count >= rule.count:
        return "raise"
    if track.active and not same:
        return "clear"
    return None


def step(rule: Rule, track: Track, value: float) -> Verdict:
    last = track.last_value
    track.last_value = value
    if last is not None and abs(value - last) > rule.step:
        track.count = 0
        return None if track.active else "raise"
    if track.active:
        track.count += 1
        if track.count >= rule.count:
            track.count = 0
            return "clear"
    return None


def refusing(rule: Rule, track: Track, ok: bool) -> Verdict:
    """``collector source``: failed contacts in a row."""
    if ok:
        track.count = 0
        return "clear" if track.active else None
    track.count += 1
    return "raise" if not track.active and track.count >= rule.count else None


READINGS = {"threshold": level, "stuck": stuck, "step": step}


# -- compiled for ingest ------------------------------------------------------------------
#
# The same three kinds as one function per rule, built once for every alarm of the rule (the
# alarm comes with each call) by :meth:`~.evaluate.Alarms.ingest`: the rule's numbers are
# locals, the ordering test (:meth:`Track.newer`) is inlined, and the common case (a
# threshold in ``ok`` on its good side) is one comparison. They must answer exactly as
# ``level``/``stuck``/``step`` above through :meth:`~.evaluate.Alarms.reading`
# (tests/collect/alarms/test_alarm_ingest.py checks it on random rules and readings).

#: ``apply(rule, track, verdict, time, value, extra)``: the transition a verdict makes.
Apply = Callable[[Rule, Track, Verdict, float, "float | None", str], "list[Transition]"]
#: ``check(alarm, time, counter, value)``: the transitions of one reading of the alarm's
#: channel (None or []: none).
Check = Callable[[Track, float, int, float], "list[Transition] | None"]


def compile_check(rule: Rule, dirty: dict[str, Track], apply: Apply) -> Check:
    """``rule`` (``threshold``, ``stuck`` or ``step``) as one function of its alarm and a
    reading; a reading it takes marks the alarm in ``dirty`` (what :meth:`Alarms.changed`
    writes)."""
    if rule.kind == "threshold":
        return (
            _level_above(rule, dirty, apply)
            if rule.direction == "above"
            else (_level_below(rule, dirty, apply))
        )
    if rule.kind == "stuck":
        return _stuck(rule, dirty, apply)
    if rule.kind == "step":
        return _step(rule, dirty, apply)
    raise ValueError(f"not a reading rule: {rule.kind}")


def _level_above(rule: Rule, dirty: dict[str, Track], apply: Apply) -> Check:
    # the rule's numbers as defaults: fast locals, and no cells to allocate
    def check(
        track: Track,
        t: float,
        c: int,
        v: float,
        limit: float = rule.limit,
        clear: float = rule.clear,
        n_raise: int = rule.count,
        n_clear: int = rule.clear_count,
        dirty: dict[str, Track] = dirty,
        apply: Apply = apply,
        rule: Rule = rule,
    ) -> list[Transition] | None:
        lt = track.last_time
        if lt is not None and (t < lt or (t == lt and c <= track.last_counter)):
            return None
        track.last_time = t
        track.last_counter = c
        dirty[track.alarm] = track
        state = track.state
        if state != "raised" and state != "acknowledged":
            if v > limit:
                n = track.count + 1
                if n >= n_raise:
                    track.count = 0
                    return apply(rule, track, "raise", t, v, "")
            else:  # the common case: on the good side, nothing happens
                track.count = 0
                return apply(rule, track, "raise", t, v, "") if n_raise <= 0 else None
        else:
            n = track.count + 1 if v <= clear else 0
            if n >= n_clear:
                track.count = 0
                return apply(rule, track, "clear", t, v, "")
        track.count = n
        return None

    return check


def _level_below(rule: Rule, dirty: dict[str, Track], apply: Apply) -> Check:
    # the rule's numbers as defaults: fast locals, and no cells to allocate
    def check(
        track: Track,
        t: float,
        c: int,
        v: float,
        limit: float = rule.limit,
        clear: float = rule.clear,
        n_raise: int = rule.count,
        n_clear: int = rule.clear_count,
        dirty: dict[str, Track] = dirty,
        apply: Apply = apply,
        rule: Rule = rule,
    ) -> list[Transition] | None:
        lt = track.last_time
        if lt is not None and (t < lt or (t == lt and c <= track.last_counter)):
            return None
        track.last_time = t
        track.last_counter = c
        dirty[track.alarm] = track
        state = track.state
        if state != "raised" and state != "acknowledged":
            if v < limit:
                n = track.count + 1
                if n >= n_raise:
                    track.count = 0
                    return apply(rule, track, "raise", t, v, "")
            else:  # the common case: on the good side, nothing happens
                track.count = 0
                return apply(rule, track, "raise", t, v, "") if n_raise <= 0 else None
        else:
            n = track.count + 1 if v >= clear else 0
            if n >= n_clear:
                track.count = 0
                return apply(rule, track, "clear", t, v, "")
        track.count = n
        return None

    return check


def _stuck(rule: Rule, dirty: dict[str, Track], apply: Apply) -> Check:
    def check(
        track: Track,
        t: float,
        c: int,
        v: float,
        tolerance: float = rule.tolerance,
        n_raise: int = rule.count,
        dirty: dict[str, Track] = dirty,
        apply: Apply = apply,
        rule: Rule = rule,
    ) -> list[Transition] | None:
        lt = track.last_time
        if lt is not None and (t < lt or (t == lt and c <= track.last_counter)):
            return None
        track.last_time = t
        track.last_counter = c
        dirty[track.alarm] = track
        last = track.last_value
        state = track.state
        if last is not None and abs(v - last) <= tolerance:
            n = track.count = track.count + 1
            if n >= n_raise and state != "raised" and state != "acknowledged":
                return apply(rule, track, "raise", t, v, "")
            return None
        track.count = 1
        track.last_value = v
        if state == "raised" or state == "acknowledged":
            return apply(rule, track, "clear", t, v, "")
        if n_raise <= 1:
            return apply(rule, track, "raise", t, v, "")
        return None

    return check


def _step(rule: Rule, dirty: dict[str, Track], apply: Apply) -> Check:
    def check(
        track: Track,
        t: float,
        c: int,
        v: float,
        jump: float = rule.step,
        n_clear: int = rule.count,
        dirty: dict[str, Track] = dirty,
        apply: Apply = apply,
        rule: Rule = rule,
    ) -> list[Transition] | None:
        lt = track.last_time
        if lt is not None and (t < lt or (t == lt and c <= track.last_counter)):
            return None
        track.last_time = t
        track.last_counter = c
        dirty[track.alarm] = track
        last = track.last_value
        track.last_value = v
        state = track.state
        active = state == "raised" or state == "acknowledged"
        if last is not None and abs(v - last) > jump:
            track.count = 0
            return None if active else apply(rule, track, "raise", t, v, f"from {last:g}")
        if active:
            n = track.count + 1
            if n >= n_clear:
                track.count = 0
                extra = f"from {last:g}" if last is not None else ""
                return apply(rule, track, "clear", t, v, extra)
            track.count = n
        return None

    return check
