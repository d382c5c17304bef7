"""Fixtures of the dashboard tests (helpers in web_store.py)."""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest
from web_store import Running, execute, insert, make_store, series_rows

from sondalog.web import create_app


@pytest.fixture
def store(tmp_path: Path) -> Path:
    """A store with logger 1001 (2 line channels + an event channel), a module, sources."""
    path = make_store(tmp_path / "store.sqlite")
    start = "2026-03-01T00:00:00"
    rows = list(series_rows("1001", 1, start, 600, 144, name="Temp", unit="°C", value=20))
    rows += series_rows("1001", 2, start, 600, 144, name="Level", unit="cm", value=100, slope=-0.2)
    rows += [
        ("1001", 3, f"2026-03-01T{h:02d}:30:00", 0, 1, float(h % 5), None, "Rain", "imp")
        for h in range(0, 24, 3)
    ]
    rows.append(("1001", 0, "2026-03-01T05:00:00", 0, 3, None, "door opened", None, None))
    rows += series_rows("bus:M1", 1, start, 3600, 24, name="RH", unit="%", value=40)
    insert(path, rows)
    execute(path, "INSERT INTO channels VALUES ('1001', 3, 'Rain', 'imp', 6)")
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_contact, record_fill, "
        "signal, credit) VALUES ('field', 'tcp://127.0.0.1:1', 'logger', '1001', 'ok', "
        "'2026-03-01T23:51:00', '1234,0.05,CLEAR', 17, 123.5)",
    )
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_error) VALUES "
        "('bus', 'tcp://127.0.0.1:2', 'bus', 'bus:M1', 'offline', 'connection refused')",
    )
    conn = sqlite3.connect(path)
    with conn:
        conn.executemany(
            "INSERT INTO events (time, source, kind, text) VALUES (?, ?, ?, ?)",
            [
                (f"2026-03-01T10:{i // 60:02d}:{i % 60:02d}", "field", "sms", f"message {i}")
                for i in range(120)
            ],
        )
    conn.close()
    return path


@pytest.fixture
def server(store: Path) -> Iterator[Running]:
    running = Running(create_app(store, poll_interval=0.2, overview_refresh=0.3))
    yield running
    running.stop()


def _services() -> object:
    """The collector tests' real servers (``tests/collect/services.py``)."""
    import sys

    here = str(Path(__file__).resolve().parents[1] / "collect")
    if here not in sys.path:
        sys.path.append(here)
    import services

    return services


@pytest.fixture(scope="session")
def postgres() -> Iterator[object]:
    """A throwaway PostgreSQL server (skipped without the binaries)."""
    yield from _services().postgres.__wrapped__()  # type: ignore[attr-defined]


@pytest.fixture
def pg_dsn(postgres: object) -> str:
    """A fresh database on the session's server."""
    return postgres.create_db()  # type: ignore[attr-defined,no-any-return]
