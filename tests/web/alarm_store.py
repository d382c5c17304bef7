"""Alarms in a dashboard test store, written the collector's way (AlarmStore.save_states and
record), and HTTP helpers for the alarm tests."""

from __future__ import annotations

import json
import sqlite3
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

from sondalog.collect.alarms import AlarmStore
from sondalog.collect.alarms.events import (
    Acknowledged,
    AlarmRecord,
    Cleared,
    Raised,
    alarm_id,
    event_key,
)

T0 = 1772323200.0  # 2026-03-01T00:00:00Z

HOT = alarm_id("Temp high", "1001/1")  # raised, on logger 1001
QUIET = alarm_id("no contact bus", "bus")  # acknowledged, on the bus source (bus:M1)
STEP = alarm_id("Level step", "1001/2")  # raised and cleared again


def add_alarms(path: Path, *, hot_rule: str = "Temp high", hot_text: str = "") -> None:
    """Three alarms: HOT raised, QUIET acknowledged, STEP cleared, with their history."""
    hot = alarm_id(hot_rule, "1001/1")
    t_hot, t_quiet, t_step = T0 + 3600, T0 + 600, T0 + 1200
    text = hot_text or "1001/1 above 40: 42.5"
    with AlarmStore(path) as store, store.transaction():
        store.save_states(
            [
                AlarmRecord(hot, hot_rule, "threshold", "1001/1", "raised",
                            event_key(hot, t_hot), 42.5, text, t_hot, t_hot, count=3),
                AlarmRecord(QUIET, "no contact bus", "no_contact", "bus", "acknowledged",
                            event_key(QUIET, t_quiet), None, "bus: no contact for 30 min",
                            t_quiet + 60, t_quiet, acked_at=t_quiet + 60),
                AlarmRecord(STEP, "Level step", "step", "1001/2", "cleared",
                            event_key(STEP, t_step), 3.0, "1001/2 jumped by 7", t_step + 300,
                            t_step, cleared_at=t_step + 300),
            ]
        )  # fmt: skip
        store.record(
            [
                Raised(QUIET, event_key(QUIET, t_quiet), "no contact bus", "no_contact", "bus",
                       t_quiet, None, "bus: no contact for 30 min"),
                Acknowledged(QUIET, event_key(QUIET, t_quiet), "no contact bus", "no_contact",
                             "bus", t_quiet + 60, None, "bus: acknowledged by anna", by="anna"),
                Raised(STEP, event_key(STEP, t_step), "Level step", "step", "1001/2", t_step,
                       7.0, "1001/2 jumped by 7"),
                Cleared(STEP, event_key(STEP, t_step), "Level step", "step", "1001/2",
                        t_step + 300, 3.0, "1001/2 calm again", raised_at=t_step),
                Raised(hot, event_key(hot, t_hot), hot_rule, "threshold", "1001/1", t_hot, 42.5,
                       text),
            ]
        )  # fmt: skip


def acks(path: Path) -> list[tuple[str, str, float, float | None]]:
    conn = sqlite3.connect(path)
    try:
        rows = conn.execute("SELECT alarm, by, requested, done FROM alarm_acks ORDER BY id")
        return [tuple(r) for r in rows]  # type: ignore[misc]
    finally:
        conn.close()


def request(
    url: str,
    *,
    method: str = "GET",
    headers: dict[str, str] | None = None,
    body: bytes | None = None,
) -> tuple[int, dict[str, str], bytes]:
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})

    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *args: Any, **kw: Any) -> None:
            return None

    opener = urllib.request.build_opener(NoRedirect)
    try:
        with opener.open(req, timeout=10) as resp:
            return resp.status, dict(resp.headers), resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def post_ack(
    base: str, alarm: str, headers: dict[str, str] | None = None, body: bytes | None = None
) -> tuple[int, Any]:
    """POST /api/alarms/ALARM/ack as the dashboard's own page would (Origin = base) unless
    ``headers`` say otherwise; (status, JSON answer)."""
    given = {"Origin": base} if headers is None else headers
    status, _, raw = request(
        f"{base}/api/alarms/{alarm}/ack", method="POST", headers=given, body=body or b""
    )
    return status, json.loads(raw) if raw else None
