"""The alarm tables on SQLite (issue 21): a restart neither forgets an alarm nor notifies
twice; two collectors on one store send each notification once."""

from __future__ import annotations

import os
import re
import sqlite3
import stat
from pathlib import Path

import pytest
from alarm_helpers import T0, plan_of, sample

from sondalog.collect.alarms import Alarms, AlarmStore, MemoryOutbox, Outbox, Policy
from sondalog.collect.alarms.dialect import POSTGRES, SQLITE
from sondalog.collect.alarms.outbox import Message
from sondalog.collect.alarms.schema import (
    ALARM_TABLES,
    CLAIM,
    POSTGRES_ALARM_DDL,
    POSTGRES_CLAIM,
    SQLITE_ALARM_DDL,
)
from sondalog.collect.alarms.store import AlarmTablesMissing

PLAN = plan_of(
    """
[[notify]]
name = "hook"
kind = "webhook"
url = "http://127.0.0.1:9/hook"
rate = "2/h"
[[alarm]]
name = "hot"
kind = "threshold"
above = 40
for = 2
notify = ["hook"]
"""
)


def step(store: AlarmStore, alarms: Alarms, policy: Policy, value: float, t: float) -> None:
    """What the runner does with a reading: transitions, notifications and states in one
    transaction."""
    with store.transaction():
        out = alarms.reading(sample(value, t))
        store.record(out)
        policy.notify(out, T0 + t)
        store.save_states(alarms.changed())


def test_files_are_private_and_in_wal_mode(tmp_path: Path) -> None:
    path = tmp_path / "state" / "alarms.sqlite"
    with AlarmStore(path) as store:
        assert store.db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600
    assert stat.S_IMODE(os.stat(path.parent).st_mode) == 0o700


def test_a_restart_neither_forgets_nor_notifies_twice(tmp_path: Path) -> None:
    path = tmp_path / "alarms.sqlite"
    with AlarmStore(path) as store:
        alarms, policy = Alarms(PLAN), Policy(PLAN, store)
        step(store, alarms, policy, 41, 0)  # one of two
    with AlarmStore(path) as store:  # restart: the count is kept
        alarms, policy = Alarms(PLAN, store.load_states()), Policy(PLAN, store)
        step(store, alarms, policy, 41, 60)
        assert [a.state for a in alarms.active()] == ["raised"]
        [m] = store.claim(T0 + 60, "c1", 120)
        # killed here, before the webhook answered
    with AlarmStore(path) as store:
        alarms, policy = Alarms(PLAN, store.load_states()), Policy(PLAN, store)
        for t in (0, 60):  # the download is read again: no second raise, no second row
            step(store, alarms, policy, 41, t)
        assert store.claim(T0 + 100, "c2", 120) == []  # still leased
        [again] = store.claim(T0 + 180, "c2", 120)
        assert again.key == m.key  # at-least-once, with the same idempotency key
        store.delivered(again.key, T0 + 181)
        assert [(x.state, x.attempts) for x in store.messages()] == [("sent", 1)]
        assert [h[1] for h in store.history()] == ["raised"]


def test_a_transaction_that_fails_stores_nothing(tmp_path: Path) -> None:
    with AlarmStore(tmp_path / "a.sqlite") as store:
        alarms, policy = Alarms(PLAN), Policy(PLAN, store)
        with pytest.raises(RuntimeError), store.transaction():
            out = alarms.readings([sample(41, 0), sample(41, 60)])
            policy.notify(out, T0)
            store.save_states(alarms.changed())
            raise RuntimeError("killed")
        assert store.messages() == [] and store.load_states() == []


def test_two_collectors_on_one_store_send_once(tmp_path: Path) -> None:
    path = tmp_path / "shared.sqlite"
    with AlarmStore(path) as one, AlarmStore(path) as two:
        for store in (one, two):  # both see the same readings
            alarms, policy = Alarms(PLAN), Policy(PLAN, store)
            step(store, alarms, policy, 41, 0)
            step(store, alarms, policy, 41, 60)
        assert len(one.messages()) == 1
        taken = one.claim(T0 + 60, "one", 120) + two.claim(T0 + 60, "two", 120)
        assert len(taken) == 1


@pytest.mark.parametrize("kind", ["memory", "sqlite"])
def test_both_outboxes_behave_alike(kind: str, tmp_path: Path) -> None:
    outbox: Outbox = (
        MemoryOutbox() if kind == "memory" else AlarmStore(tmp_path / "o.sqlite").open()
    )
    m = Message("e/raised/d", "d", "raised", "e", "text", T0, T0)
    assert outbox.add(m) and not outbox.add(m) and outbox.has(m.key)
    s = Message("s/summary/d", "d", "summary", "s", "one", T0, T0 + 10)
    assert outbox.add(s) and outbox.extend_summary(s.key, "two")
    assert outbox.count_since("d", T0) == 1 and outbox.count_since("d", T0 + 1) == 0
    assert [x.key for x in outbox.claim(T0, "me", 5)] == [m.key]
    assert outbox.next_try() == T0 + 5
    outbox.failed(m.key, T0 + 1, "down", T0 + 20)
    assert outbox.next_try() == T0 + 10
    [summary] = outbox.claim(T0 + 10, "me", 5)
    assert (summary.text, summary.items) == ("one\ntwo", 2)
    outbox.delivered(summary.key, T0 + 11)
    [retry] = outbox.claim(T0 + 20, "me", 5)
    assert (retry.attempts, retry.last_error) == (1, "down")
    outbox.failed(m.key, T0 + 21, "gone", None)
    assert outbox.next_try() is None
    states = {x.key: (x.state, x.attempts) for x in outbox.messages()}
    assert states == {m.key: ("failed", 2), s.key: ("sent", 1)}


def test_the_postgres_ddl_has_the_same_tables() -> None:
    for table in ("alarm_states", "alarm_events", "alarm_outbox"):
        assert f"CREATE TABLE IF NOT EXISTS {table}" in POSTGRES_ALARM_DDL
    assert "REAL" not in POSTGRES_ALARM_DDL and "AUTOINCREMENT" not in POSTGRES_ALARM_DDL


def test_acknowledgements_asked_by_another_process_are_taken_once(tmp_path: Path) -> None:
    from sondalog.collect.alarms.events import AlarmRecord

    path = tmp_path / "alarms.sqlite"
    with AlarmStore(path) as store:
        store.save_states([AlarmRecord("A1", "r", "threshold", "s", state="raised")])
        assert not store.request_ack("nope", "ops", 10.0)
    with AlarmStore(path) as other:  # the dashboard or the CLI
        assert other.request_ack("A1", "ops", 11.0)
    with AlarmStore(path) as store:
        assert store.take_ack_requests(12.0) == [("A1", "ops", 11.0)]
        assert store.take_ack_requests(13.0) == []


def test_the_documented_schema_is_the_one_the_stores_create() -> None:
    """docs/alarms.md "The schema": its SQL blocks are the DDL of both servers and the
    claim, word for word (spaces aside)."""
    doc = (Path(__file__).resolve().parents[3] / "docs" / "alarms.md").read_text()
    blocks = re.findall(r"```sql\n(.*?)```", doc, re.S)

    def words(text: str) -> list[str]:
        return text.replace(";", " ").split()

    assert [words(b) for b in blocks] == [
        words(SQLITE_ALARM_DDL),
        words(POSTGRES_ALARM_DDL),
        words(POSTGRES_CLAIM),
    ]
    for table in ALARM_TABLES:
        assert f"`{table}`" in doc


def test_the_statements_are_written_once_for_both_dialects() -> None:
    assert SQLITE.sql(CLAIM) == CLAIM.format(skip_locked="")
    assert "%s" in POSTGRES_CLAIM and "?" not in POSTGRES_CLAIM
    assert POSTGRES_CLAIM.count("%s") == CLAIM.count("?") == 5
    assert "FOR UPDATE SKIP LOCKED" in POSTGRES_CLAIM
    assert SQLITE.sql("SELECT 1 FROM t WHERE a = ?{lock}") == "SELECT 1 FROM t WHERE a = ?"
    assert POSTGRES.sql("SELECT 1 FROM t WHERE a = ?{lock}").endswith("a = %s FOR UPDATE")
    with pytest.raises(ValueError, match="literal %"):
        POSTGRES.sql("SELECT 1 WHERE a LIKE 'x%'")


def test_the_dashboard_reads_without_writing(tmp_path: Path) -> None:
    """``read_only=True``: nothing is created; a file without the tables has no alarms."""
    from sondalog.collect.alarms.events import AlarmRecord

    path = tmp_path / "alarms.sqlite"
    with pytest.raises(AlarmTablesMissing, match="does not exist"):
        AlarmStore(path, read_only=True).open()
    assert not path.exists()
    sqlite3.connect(path).execute("CREATE TABLE readings (x)").connection.close()
    with pytest.raises(AlarmTablesMissing, match="has no alarm_"):
        AlarmStore(path, read_only=True).open()
    with AlarmStore(path) as store:
        store.save_states(
            [
                AlarmRecord("A1", "r", "threshold", "s", "raised", since=5.0, raised_at=5.0),
                AlarmRecord("A2", "r", "threshold", "t", "cleared", since=9.0),
                AlarmRecord("A3", "r", "threshold", "u", "acknowledged", since=7.0),
            ]
        )
        assert store.request_ack("A1", "ops", 10.0)
    with AlarmStore(path, read_only=True) as reader:
        assert [r.alarm for r in reader.active_states()] == ["A3", "A1"]
        assert (reader.state_of("A2"), reader.state_of("nope")) == ("cleared", None)
        assert reader.waiting_acks() == {"A1"}
        with pytest.raises(sqlite3.OperationalError, match="readonly"):
            reader.request_ack("A1", "ops", 11.0)
