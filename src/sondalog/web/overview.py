"""The overview's data: every logger and module, its sources, last values and trouble.

A source is *in trouble* when its ``state`` is anything but ``ok`` or ``new``, or when it
has a ``last_error`` and its state is not ``ok`` (``sources`` table, schema version 1).
"""

from __future__ import annotations

from typing import Any

from . import store

#: Source states that are not trouble (a source being contacted is in trouble only when its
#: last contact failed: its ``last_error`` is kept until a contact succeeds).
GOOD_STATES = frozenset({"ok", "new", "contacting"})


def in_trouble(source: dict[str, Any]) -> bool:
    state = str(source.get("state") or "new").lower()
    if state not in GOOD_STATES:
        return True
    return bool(source.get("last_error")) and state != "ok"


def channel_json(c: store.Channel) -> dict[str, Any]:
    return {
        "channel": c.channel,
        "name": c.name,
        "unit": c.unit,
        "kind": c.kind,
        "time": c.last_time,
        "value": c.last_value,
        "decimals": c.decimals,
    }


def source_json(s: dict[str, Any]) -> dict[str, Any]:
    keys = ("name", "url", "kind", "logger", "state", "last_contact", "last_error")
    out = {k: s.get(k) for k in keys}
    out.update(
        record_fill=s.get("record_fill"),
        signal=s.get("signal"),
        credit=s.get("credit"),
        offset_s=s.get("offset_s"),
        trouble=in_trouble(s),
    )
    return out


def logger_json(db: store.Db, logger: str, srcs: list[dict[str, Any]]) -> dict[str, Any]:
    """One logger's overview entry."""
    mine = [source_json(s) for s in srcs if s.get("logger") == logger]
    chans = store.channels(db, logger)
    contacts = [s["last_contact"] for s in mine if s["last_contact"]]
    last = store.last_time(db, logger)
    return {
        "logger": logger,
        "module": logger.startswith("bus:"),
        "last_reading": last,
        "last_contact": max(contacts) if contacts else None,
        "offset_s": _first(
            sorted(mine, key=lambda s: s["last_contact"] or "", reverse=True), "offset_s"
        ),
        "record_fill": _first(mine, "record_fill"),
        "signal": _first(mine, "signal"),
        "credit": _first(mine, "credit"),
        "trouble": any(s["trouble"] for s in mine),
        "sources": mine,
        "channels": [channel_json(c) for c in chans],
    }


def _first(items: list[dict[str, Any]], key: str) -> Any:
    for item in items:
        if item.get(key) is not None:
            return item[key]
    return None


def overview(db: store.Db) -> dict[str, Any]:
    """Every logger, and the sources not (yet) tied to a logger."""
    srcs = store.sources(db)
    return {
        "loggers": [logger_json(db, lg, srcs) for lg in store.loggers(db)],
        "unbound_sources": [source_json(s) for s in srcs if not s.get("logger")],
    }
