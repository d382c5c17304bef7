"""The alarm tables on a real PostgreSQL (issue 21): the same behaviour as on SQLite, and
several collectors on one server notify once per event."""

from __future__ import annotations

from pathlib import Path

import pytest
from alarm_helpers import T0, plan_of, sample

from sondalog.collect.alarm_loop import alarm_store
from sondalog.collect.alarms import Alarms, AlarmStore, Policy
from sondalog.collect.alarms.events import AlarmRecord
from sondalog.collect.alarms.outbox import Message
from sondalog.collect.alarms.store_pg import PostgresAlarmStore
from sondalog.collect.config import load_config
from sondalog.config import ConfigError

PLAN = plan_of(
    """
[[notify]]
name = "hook"
kind = "webhook"
url = "http://127.0.0.1:9/hook"
repeat = "10m"
[[alarm]]
name = "hot"
kind = "threshold"
above = 40
for = 2
notify = ["hook"]
"""
)


def step(store: PostgresAlarmStore, alarms: Alarms, policy: Policy, value: float, t: float) -> None:
    with store.transaction():
        out = alarms.reading(sample(value, t))
        store.record(out)
        policy.notify(out, T0 + t)
        store.save_changes(alarms.changes())


def test_a_restart_neither_forgets_nor_notifies_twice(pg_dsn: str) -> None:
    with PostgresAlarmStore(pg_dsn) as store:
        alarms, policy = Alarms(PLAN), Policy(PLAN, store)
        step(store, alarms, policy, 41, 0)  # one of two
    with PostgresAlarmStore(pg_dsn) as store:  # restart: the count is kept
        alarms, policy = Alarms(PLAN, store.load_states()), Policy(PLAN, store)
        step(store, alarms, policy, 41, 60)
        assert [a.state for a in alarms.active()] == ["raised"]
        [m] = store.claim(T0 + 60, "c1", 120)
    with PostgresAlarmStore(pg_dsn) as store:
        alarms, policy = Alarms(PLAN, store.load_states()), Policy(PLAN, store)
        for t in (0, 60):  # the download read again: no second raise, no second row
            step(store, alarms, policy, 41, t)
        assert store.claim(T0 + 100, "c2", 120) == []  # still leased
        [again] = store.claim(T0 + 180, "c2", 120)
        assert again.key == m.key
        store.delivered(again.key, T0 + 181)
        assert [(x.state, x.attempts) for x in store.messages()] == [("sent", 1)]
        assert [h[1] for h in store.history()] == ["raised"]
        assert store.release("c2") == 0


def test_two_collectors_on_one_server_notify_once(pg_dsn: str) -> None:
    with PostgresAlarmStore(pg_dsn) as one, PostgresAlarmStore(pg_dsn) as two:
        runs = [(s, Alarms(PLAN), Policy(PLAN, s)) for s in (one, two)]
        for t in (0, 60):  # both see the same readings, interleaved
            for store, alarms, policy in runs:
                step(store, alarms, policy, 41, t)
        assert len(one.messages()) == 1 and [h[1] for h in two.history()] == ["raised"]
        taken = one.claim(T0 + 60, "one", 120) + two.claim(T0 + 60, "two", 120)
        assert len(taken) == 1
        for store, alarms, policy in runs:  # repeats are computed alike: one row each
            with store.transaction():
                policy.repeats(alarms.active(), T0 + 60 + 600)
        assert [m.what for m in two.messages()] == ["raised", "repeat"]


def test_an_acknowledgement_reaches_every_collector_once(pg_dsn: str) -> None:
    with PostgresAlarmStore(pg_dsn) as one, PostgresAlarmStore(pg_dsn) as two:
        one.save_states([AlarmRecord("A1", "r", "threshold", "s", state="raised")])
        assert not one.request_ack("nope", "ops", 10.0)
        with PostgresAlarmStore(pg_dsn) as person:  # the dashboard or the CLI
            assert person.request_ack("A1", "ops", 11.0)
        assert one.take_ack_requests(12.0) == [("A1", "ops", 11.0)]
        assert one.take_ack_requests(13.0) == []
        assert two.take_ack_requests(14.0) == [("A1", "ops", 11.0)]  # stops its repeats too
        assert two.take_ack_requests(15.0) == []
        done = one.db.execute("SELECT done FROM alarm_acks").fetchall()
        assert done == [(12.0,)]
    with PostgresAlarmStore(pg_dsn) as restarted:  # applied before: its state is stored
        assert restarted.take_ack_requests(16.0) == []


def test_a_transaction_that_fails_stores_nothing(pg_dsn: str) -> None:
    with PostgresAlarmStore(pg_dsn) as store:
        alarms, policy = Alarms(PLAN), Policy(PLAN, store)
        with pytest.raises(RuntimeError), store.transaction():
            out = alarms.readings([sample(41, 0), sample(41, 60)])
            store.record(out)
            policy.notify(out, T0)
            store.save_states(alarms.changed())
            raise RuntimeError("killed")
        assert store.messages() == [] and store.load_states() == [] and store.history() == []


def test_the_outbox_behaves_as_on_sqlite(pg_dsn: str, tmp_path: Path) -> None:
    seen = []
    for outbox in (PostgresAlarmStore(pg_dsn).open(), AlarmStore(tmp_path / "o.sqlite").open()):
        m = Message("e/raised/d", "d", "raised", "e", "text", T0, T0)
        assert outbox.add(m) and not outbox.add(m) and outbox.has(m.key)
        s = Message("s/summary/d", "d", "summary", "s", "one", T0, T0 + 10)
        assert outbox.add(s) and outbox.extend_summary(s.key, "two")
        assert outbox.count_since("d", T0) == 1 and outbox.count_since("d", T0 + 1) == 0
        assert [x.key for x in outbox.claim(T0, "me", 5)] == [m.key]
        assert outbox.next_try() == T0 + 5
        outbox.failed(m.key, T0 + 1, "down", T0 + 20)
        [summary] = outbox.claim(T0 + 10, "me", 5)
        outbox.delivered(summary.key, T0 + 11)
        outbox.failed(m.key, T0 + 21, "gone", None)
        seen.append((summary.text, summary.items, outbox.messages()))
        outbox.close()
    assert seen[0] == seen[1]


def test_a_lost_connection_is_opened_again(pg_dsn: str) -> None:
    with PostgresAlarmStore(pg_dsn) as store:
        pid = store.db.execute("SELECT pg_backend_pid()").fetchone()
        with PostgresAlarmStore(pg_dsn) as other:
            other.db.execute("SELECT pg_terminate_backend(%s)", pid)
        with pytest.raises(Exception):  # noqa: B017 - the failing call raises psycopg's error
            store.load_states()
        assert store.load_states() == []


def _config(tmp: Path, postgres: str) -> Path:
    path = tmp / "collector.toml"
    path.write_text(
        f'[postgres]\ndsn = "host=127.0.0.1"\n{postgres}\n'
        '[[source]]\nurl = "serial:///dev/null"\nname = "s"\n'
    )
    return path


def test_alarms_true_in_postgres_puts_the_alarm_tables_there(tmp_path: Path) -> None:
    store = alarm_store(load_config(_config(tmp_path, "alarms = true")))
    assert isinstance(store, PostgresAlarmStore) and store.dsn == "host=127.0.0.1"
    assert isinstance(alarm_store(load_config(_config(tmp_path, ""))), AlarmStore)
    with pytest.raises(ConfigError, match=r"collector.toml:3: postgres.alarms: must be true"):
        load_config(_config(tmp_path, 'alarms = "yes"'))


def test_a_write_lost_with_the_connection_is_computed_again(pg_dsn: str, tmp_path: Path) -> None:
    """The server drops the collector's connection while a batch raises: the batch fails
    (its cursor is not committed), and reading it again raises and notifies after all."""
    from datetime import datetime

    from sondalog.collect.alarm_loop import AlarmLoop
    from sondalog.collect.model import Reading
    from sondalog.collect.store_sqlite import SqliteStore

    path = tmp_path / "collector.toml"
    path.write_text(
        f'[postgres]\ndsn = "{pg_dsn}"\nalarms = true\n\n'
        '[[source]]\nurl = "tcp://127.0.0.1:1"\nname = "s"\n\n'
        '[[notify]]\nname = "log"\nkind = "log"\n\n'
        '[[alarm]]\nname = "hot"\nkind = "threshold"\nchannel = 1\nabove = 40\nnotify = ["log"]\n'
    )
    config = load_config(path)
    sqlite = SqliteStore(config.store).open_sync()
    loop = AlarmLoop(config)
    loop.open(sqlite, config.sources)
    store = loop.store
    assert isinstance(store, PostgresAlarmStore)
    batch = [Reading("F01", 1, datetime(2026, 1, 1, 12), 1, 3, 41.0)]
    pid = store.db.execute("SELECT pg_backend_pid()").fetchone()
    with PostgresAlarmStore(pg_dsn) as other:
        other.db.execute("SELECT pg_terminate_backend(%s)", pid)
    with pytest.raises(Exception):  # noqa: B017 - psycopg's OperationalError
        loop.readings("s", batch)
    loop.contact("s", ok=False, error="the batch failed")  # logged, never raised
    loop.readings("s", batch)  # read again after the failed contact
    assert [m.what for m in store.messages()] == ["raised"]
    assert [r.state for r in store.load_states() if r.rule == "hot"] == ["raised"]
    store.close()
    sqlite.close_sync()


def test_the_dashboards_reads_behave_as_on_sqlite(pg_dsn: str, tmp_path: Path) -> None:
    """active_states, state_of, waiting_acks and history: one set of statements, the same
    answers from both servers."""
    from sondalog.collect.alarms.events import Raised

    seen = []
    for store in (PostgresAlarmStore(pg_dsn).open(), AlarmStore(tmp_path / "a.sqlite").open()):
        store.save_states(
            [
                AlarmRecord("A1", "r", "threshold", "s", "raised", "e1", 41.0, "hot", 5.0, 5.0),
                AlarmRecord("A2", "r", "threshold", "t", "cleared", since=9.0),
                AlarmRecord("A3", "r", "no_contact", "u", "acknowledged", since=7.0),
            ]
        )
        store.record([Raised("A1", "e1", "r", "threshold", "s", 5.0, 41.0, "hot")] * 2)
        assert store.request_ack("A1", "ops", 10.0) and not store.request_ack("A2", "ops", 10.0)
        seen.append(
            (
                store.active_states(),
                [store.state_of(a) for a in ("A1", "A2", "nope")],
                store.waiting_acks(),
                store.history(),
                store.take_ack_requests(11.0),
                store.waiting_acks(),
            )
        )
        store.close()
    assert seen[0] == seen[1]
    active, states, waiting, history, taken, after = seen[0]
    assert [r.alarm for r in active] == ["A3", "A1"] and states == ["raised", "cleared", None]
    assert waiting == {"A1"} and after == set() and taken == [("A1", "ops", 10.0)]
    assert history == [(5.0, "raised", "A1", "r", "s", 41.0, "hot")]
