"""``[[alarm]]`` tables of the collector's file -> :class:`~.rules.AlarmPlan` (issue 21).

Read through the typed config reader (:class:`sondalog.config.Table`): every kind refuses
keys it does not use with a "did you mean", and every error is ``FILE:LINE: alarm[2].for:
...``. ``[[notify]]`` tables are read by :mod:`.parse_notify`; every name in an alarm's
``notify`` must be one of them.

::

    [[alarm]]
    kind = "threshold"
    logger = "F*"               # a glob on the serial number (default: every logger)
    channel = "Air"             # by number (3) or by name; default: every channel
    above = 40                  # or below = ...
    clear = 38                  # hysteresis: clears at or below 38 (default: the limit)
    for = 3                     # consecutive readings to raise, and to clear
    notify = ["ops-mail", "oncall-sms"]
"""

from __future__ import annotations

import difflib
from dataclasses import replace
from typing import Any, Literal

from sondalog.config import Table

from .durations import duration
from .parse_notify import parse_notify
from .rules import COLLECTOR_WATCHES, HEALTH_MEASURES, RULE_KINDS, AlarmPlan, Rule

_COMMON = {"name", "kind", "notify", "logger", "source"}
KEYS: dict[str, set[str]] = {
    "no_contact": _COMMON | {"after"},
    "threshold": _COMMON | {"channel", "above", "below", "clear", "for"},
    "stuck": _COMMON | {"channel", "for", "tolerance"},
    "step": _COMMON | {"channel", "step", "for"},
    "health": _COMMON | {"measure", "above", "below", "clear", "for"},
    "collector": {"name", "kind", "notify", "watch", "sink", "source", "above", "clear", "for"}
    | {"after"},
}
_ALL_KEYS = set().union(*KEYS.values())


def parse_alarms(root: Table) -> AlarmPlan:
    """The ``[[alarm]]`` and ``[[notify]]`` tables of the collector's file ``root``;
    raises :class:`sondalog.config.ConfigError`."""
    notify = parse_notify(root)
    rules: list[Rule] = []
    seen: dict[str, str] = {}
    for table in root.tables("alarm", keys=_ALL_KEYS):
        rule = _rule(table, set(notify))
        if rule.name in seen:
            key = "name" if "name" in table else None
            raise table.fail(
                key,
                f"{rule.name!r} is the name of {seen[rule.name]} too: give each rule its own "
                'name = "..." (it is the alarm\'s id in the store)',
            )
        seen[rule.name] = table.field()
        rules.append(rule)
    return AlarmPlan(tuple(rules), notify)


def _rule(t: Table, destinations: set[str]) -> Rule:
    kind = t.text("kind", choices=RULE_KINDS)
    t.keys(KEYS[kind])
    notify = tuple(t.texts("notify", []))
    for i, name in enumerate(notify):
        if name not in destinations:
            close = difflib.get_close_matches(name, sorted(destinations), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            known = ", ".join(sorted(destinations)) or "none"
            raise t.fail("notify", f"item {i}: no [[notify]] named {name!r} ({hint}known: {known})")
    fields: dict[str, Any] = {
        "kind": kind,
        "notify": notify,
        "logger": t.text("logger", "*"),
        "source": t.text("source", "*"),
        "line": t.line(),
    }
    match kind:
        case "no_contact":
            fields["after"] = duration(t, "after")
        case "threshold":
            fields |= _limit(t) | _channel(t)
            fields["clear_count"] = fields["count"]
        case "stuck":
            fields["count"] = t.integer("for", 10, lo=2, what="a count of readings >= 2")
            fields["tolerance"] = t.number("tolerance", 0.0, lo=0)
            fields |= _channel(t)
        case "step":
            fields["step"] = t.number("step", lo=0)
            fields["count"] = t.integer("for", 1, lo=1, what="a count of calm readings >= 1")
            fields |= _channel(t)
        case "health":
            fields |= _health(t)
            fields["clear_count"] = fields["count"]
        case _:
            fields |= _collector(t)
    rule = Rule(name="", **fields)
    return replace(rule, name=t.text("name", _default_name(rule)))


def _channel(t: Table) -> dict[str, Any]:
    if t.is_text("channel"):
        return {"channel_name": t.text("channel")}
    return {"channel": t.opt_integer("channel", lo=1, what="a channel number >= 1 or a name")}


def _limit(t: Table, only: Literal["above", "below"] | None = None) -> dict[str, Any]:
    """``above``/``below`` (exactly one), ``clear`` on its good side, ``for``."""
    given = [k for k in ("above", "below") if k in t]
    if len(given) != 1:
        key = given[1] if given else None
        raise t.fail(key, "give exactly one of above = ... or below = ...")
    direction = given[0]
    if only is not None and direction != only:
        raise t.fail(direction, f"this measure is bad {only} a limit: use {only} = ...")
    limit = t.number(direction)
    clear = t.number("clear", limit)
    if (direction == "above" and clear > limit) or (direction == "below" and clear < limit):
        side = "at or below" if direction == "above" else "at or above"
        raise t.fail("clear", f"must be {side} the limit {limit:g} (hysteresis), not {clear:g}")
    count = t.integer("for", 1, lo=1, what="a count of readings >= 1")
    return {"direction": direction, "limit": limit, "clear": clear, "count": count}


def _health(t: Table) -> dict[str, Any]:
    measure = t.text("measure", choices=HEALTH_MEASURES)
    bad = HEALTH_MEASURES[measure]
    if measure in ("gaps", "drift") and not ("above" in t or "below" in t):
        limits: dict[str, Any] = {"direction": "above", "limit": 0.0, "clear": 0.0, "count": 1}
    else:
        limits = _limit(t, bad)
    if measure == "memory" and not 0 <= limits["limit"] <= 1:
        raise t.fail(bad, "must be a fill ratio 0..1 (0.9: 90 % full)")
    return {"measure": measure, **limits}


def _collector(t: Table) -> dict[str, Any]:
    watch = t.text("watch", choices=COLLECTOR_WATCHES)
    used = {"sink": ("sink", "buffer"), "after": ("sink",), "above": ("buffer",)}
    used |= {"clear": ("buffer",), "for": ("source",), "source": ("source",)}
    for key, watches in used.items():
        if key in t and watch not in watches:
            raise t.fail(key, f"is not used by watch = {watch!r} (used by {', '.join(watches)})")
    fields: dict[str, Any] = {"watch": watch, "sink": t.text("sink", "*")}
    match watch:
        case "sink":  # raised when a sink has been down ``after`` seconds; clears when up
            fields["after"] = duration(t, "after", 60.0)
        case "buffer":  # batches waiting for a sink; clears when drained to ``clear``
            above = t.number("above", lo=0, what="a count of batches >= 0")
            clear = t.number("clear", 0.0, lo=0, hi=above, what=f"a count 0..{above:g}")
            fields |= {"limit": above, "clear": clear}
        case _:  # failed contacts in a row; clears at the next good one
            fields["count"] = t.integer("for", 3, lo=1, what="a count of failed contacts >= 1")
    return fields


def _default_name(rule: Rule) -> str:
    """A name made of what the rule watches: ``threshold F*/Air above 40``."""
    who = rule.logger if rule.logger != "*" else rule.source
    chan = rule.channel if rule.channel is not None else rule.channel_name
    where = f"{who}/{chan}" if chan is not None else who
    match rule.kind:
        case "threshold":
            return f"threshold {where} {rule.direction} {rule.limit:g}"
        case "health":
            return f"health {who} {rule.measure} {rule.direction} {rule.limit:g}"
        case "stuck" | "step":
            return f"{rule.kind} {where}"
        case "collector":
            return f"collector {rule.watch} {rule.source if rule.watch == 'source' else rule.sink}"
    return f"{rule.kind} {who}"
