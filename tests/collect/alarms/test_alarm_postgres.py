"""The PostgreSQL schema of docs/alarms.md on a real server: the DDL runs, a notification
computed by two collectors is one row, and a claim hands a row to one of them."""

from __future__ import annotations

import psycopg

from sondalog.collect.alarms.schema import POSTGRES_ALARM_DDL, POSTGRES_CLAIM

ADD = (
    "INSERT INTO alarm_outbox (key, destination, what, event, text, created, next_try) "
    "VALUES (%s, 'hook', 'raised', 'e1', 'hot', 1, 1) ON CONFLICT (key) DO NOTHING"
)


def test_two_collectors_share_the_outbox(pg_dsn: str) -> None:
    with psycopg.connect(pg_dsn, autocommit=True) as one, psycopg.connect(pg_dsn) as two:
        one.execute(POSTGRES_ALARM_DDL)
        one.execute(POSTGRES_ALARM_DDL)  # additive: runs again on every start
        assert one.execute(ADD, ("e1/raised/hook",)).rowcount == 1
        assert one.execute(ADD, ("e1/raised/hook",)).rowcount == 0  # the second collector
        args = {"owner": "two", "until": 200.0, "now": 10.0, "limit": 10}
        taken_by_two = two.execute(POSTGRES_CLAIM, args).fetchall()  # not committed yet
        taken_by_one = one.execute(POSTGRES_CLAIM, args | {"owner": "one"}).fetchall()
        assert taken_by_two == [("e1/raised/hook",)] and taken_by_one == []
        two.commit()
        assert one.execute(POSTGRES_CLAIM, args | {"owner": "one"}).fetchall() == []  # leased
        later = args | {"owner": "one", "now": 200.0, "until": 400.0}
        assert one.execute(POSTGRES_CLAIM, later).fetchall() == [("e1/raised/hook",)]
