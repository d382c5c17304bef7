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

        def claim(conn: psycopg.Connection[tuple[object, ...]], *args: object) -> list[object]:
            """POSTGRES_CLAIM (owner, lease end, now, now, limit): the keys it hands out."""
            return [row[0] for row in conn.execute(POSTGRES_CLAIM, args).fetchall()]

        taken_by_two = claim(two, "two", 200.0, 10.0, 10.0, 10)  # not committed yet
        taken_by_one = claim(one, "one", 200.0, 10.0, 10.0, 10)
        assert taken_by_two == ["e1/raised/hook"] and taken_by_one == []
        two.commit()
        assert claim(one, "one", 200.0, 10.0, 10.0, 10) == []  # leased
        assert claim(one, "one", 400.0, 200.0, 200.0, 10) == ["e1/raised/hook"]
        [row] = one.execute("SELECT claimed_by, claimed_until FROM alarm_outbox").fetchall()
        assert row == ("one", 400.0)
