"""Arrays encoded at once (:mod:`sondalog.collect.pg_arrays`) against a real server: what it
reads from them is exactly what it reads from psycopg's own dumping of the same lists (the
way the block upsert passed them before), on random arrays."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterator, Sequence
from datetime import datetime
from typing import Any

import psycopg
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from services import PostgresServer

from sondalog.collect import blocks_rule, blocks_sql, pg_arrays, schema_pg
from sondalog.collect.model import Reading


@pytest.fixture(scope="module")
def conn(postgres: PostgresServer) -> Iterator[psycopg.Connection[Any]]:
    with psycopg.connect(postgres.dsn(), autocommit=True) as c:
        pg_arrays.register(c)
        yield c


def sent(conn: psycopg.Connection[Any], cast: str, value: object) -> bytes:
    """The server's binary form (``array_send``) of ``value`` read as ``cast``."""
    row = conn.execute(f"SELECT array_send(%b::{cast})", [value]).fetchone()  # type: ignore[arg-type]
    assert row is not None
    return bytes(row[0])


FLOATS = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True))
TEXTS = st.one_of(st.none(), st.text(max_size=6))
CASES: list[tuple[str, Callable[..., pg_arrays.Array], Any]] = [
    ("int[]", pg_arrays.int4s, st.lists(st.integers(-(2**31), 2**31 - 1), max_size=40)),
    ("bigint[]", pg_arrays.int8s, st.lists(st.integers(-(2**63), 2**63 - 1), max_size=40)),
    ("float8[]", pg_arrays.float8s, st.lists(FLOATS, max_size=40)),
    ("text[]", pg_arrays.texts, st.lists(TEXTS, max_size=40)),
]


@pytest.mark.parametrize(("cast", "encode", "items"), CASES, ids=[c[0] for c in CASES])
def test_an_array_reads_as_psycopgs_list(
    conn: psycopg.Connection[Any], cast: str, encode: Callable[..., pg_arrays.Array], items: Any
) -> None:
    @settings(max_examples=150, deadline=None)
    @given(items)
    def check(values: Sequence[Any]) -> None:
        plain = values
        if cast == "text[]":  # NUL is dropped, which PostgreSQL text cannot hold
            plain = [None if v is None else v.replace("\x00", "") for v in values]
        # psycopg's list (its text form for an empty list, which it cannot type in binary)
        before = sent(conn, cast, plain if plain else "{}")
        assert sent(conn, cast, encode(values)) == before

    check()


def test_the_block_upsert_parameters_read_as_before(conn: psycopg.Connection[Any]) -> None:
    """The eight columns of a batch's blocks (as ``blocks_rule.aggregate`` makes them),
    NULL extremes and NaN among them, read by the upsert's casts."""
    blocks = [
        ("L1", 1800, 1_767_225_600, 1, 1.5, 1_767_225_660, 2.5, 1_767_225_720),
        ("L\x002", 7200, 1_767_225_600, 3, None, 1_767_225_600, math.nan, 1_767_225_600),
        ("L1", 86400, 1_767_225_600, 12, -0.0, 1_767_225_600, math.inf, 1_767_225_601),
    ]
    casts = ["text[]", "int[]", "bigint[]", "int[]", "float8[]", "bigint[]", "float8[]", "bigint[]"]
    columns = [list(c) for c in zip(*blocks, strict=True)]
    columns[0] = [t.replace("\x00", "") for t in columns[0]]
    for cast, new, old in zip(casts, blocks_sql.upsert_params(blocks), columns, strict=True):
        assert sent(conn, cast, new) == sent(conn, cast, old)


def test_a_connection_made_before_the_first_upsert_takes_them(pg_dsn: str) -> None:
    """The sink's connections exist before the module that encodes the arrays is first
    used: the first batch registers them on its connection and cursor (a connection copies
    psycopg's adapters when it is made; an array it does not know goes as ``bytea``)."""
    batch = [Reading("L1", ch, datetime(2026, 1, 1, 0, m), 0, 1, float(m)) for m in range(3)
             for ch in (1, 2)]  # fmt: skip

    async def run() -> None:
        async with await psycopg.AsyncConnection.connect(pg_dsn, autocommit=True) as conn:
            for sql in schema_pg.statements(0):  # record_rows, which the tables' making reads
                await conn.execute(sql)  # type: ignore[arg-type]
            for _ in range(2):  # the first cursor, and one made after
                async with conn.transaction(), conn.cursor() as cur:
                    await blocks_sql.after_batch_postgres(
                        cur, batch, len(batch), blocks_rule.aggregate(batch)
                    )

    asyncio.run(run())
    with psycopg.connect(pg_dsn) as c:
        got = c.execute("SELECT count(*) FROM readings_extremes").fetchone()
    assert got == (len(blocks_rule.aggregate(batch)),)
