"""The collector with its dashboard in one event loop (``sondalog collect``, ``make demo``).

The collector (:mod:`sondalog.collect`) does not know the dashboard (the web sits above it in
the package map); this wiring runs both: :class:`~sondalog.collect.runner.Collector` and,
unless ``[web] enabled = false``, :func:`sondalog.web.serve` over the same SQLite store (and
the same alarm store: the file's, or the ``[postgres]`` server's with ``alarms = true``), as
tasks of the caller's loop. Stopping the collector stops the dashboard.

A busy *default* port (no ``[web] listen`` in the file) is a warning and the collector runs
without its dashboard: collecting is its job, and a second collector on one machine must not
fail for it. A busy port the file asks for is an error (:class:`WebUnavailable`).

The dashboard reads the readings from the store of record that ``[web] readings`` names
(:func:`~sondalog.collect.web_config.readings_on_server`: the file, or the ``[postgres]``
server). Before it serves, the per-block extremes of its long ranges are made there once
(:mod:`sondalog.web.blocks`: a table filled from the stored rows, then kept by a trigger at
ingest); a server that cannot be reached yet is tried again every :data:`BLOCKS_RETRY_S`.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import sqlite3
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sondalog.collect.alarm_loop import alarm_store
from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector
from sondalog.collect.web_config import readings_on_server
from sondalog.web import blocks, create_app, serve
from sondalog.web.server import bind

log = logging.getLogger(__name__)
#: Seconds between tries to make the per-block extremes on a server not reachable yet.
BLOCKS_RETRY_S = 60.0


class WebUnavailable(OSError):
    """The dashboard cannot listen where the configuration says."""


async def run_collector(
    collector: Collector,
    stop: asyncio.Event,
    *,
    once: bool = False,
    on_web: Callable[[str, int], None] | None = None,
    poll_interval: float = 1.0,
) -> None:
    """Run ``collector`` until ``stop``, serving the dashboard beside it (not with ``once``).

    ``on_web(host, port)`` is called once the dashboard listens. Raises
    :class:`WebUnavailable` when the address the file names cannot be used.
    """
    web = collector.config.web
    task: asyncio.Task[None] | None = None
    helpers: list[asyncio.Task[None]] = []
    if web.enabled and not once:
        try:
            bind(web.host, web.port).close()  # a clear error before anything starts
        except OSError as exc:
            where = f"{web.host}:{web.port}"
            if web.explicit:
                raise WebUnavailable(
                    f"the dashboard cannot listen on {where}: {exc.strerror or exc} "
                    "(choose another [web] listen, or port 0 for any free port)"
                ) from exc
            log.warning(
                "the dashboard is not served: %s is taken (%s); set [web] listen",
                where,
                exc.strerror or exc,
            )
        else:
            dsn = readings_dsn(collector)
            if not web.blocks:
                pass  # [web] blocks = false: the store is left as it is
            elif dsn is None:
                await asyncio.to_thread(_blocks_in_file, collector.config.store)
            else:
                helpers.append(asyncio.create_task(_blocks_on_server(dsn), name="blocks"))
            app = create_app(
                collector.config.store,
                token=web.token,
                poll_interval=poll_interval,
                alarm_store=alarm_store(collector.config),  # its file, or [postgres]
                readings_dsn=dsn,
            )
            task = asyncio.create_task(
                serve(
                    app,
                    web.host,
                    web.port,
                    allow_remote=web.allow_remote,
                    token=web.token,
                    on_listen=on_web,
                ),
                name="dashboard",
            )
            task.add_done_callback(_report)
    try:
        await collector.run(stop, once=once)
    finally:
        for helper in helpers:
            helper.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await helper
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task


def readings_dsn(collector: Collector) -> str | None:
    """The ``[postgres]`` server the dashboard reads the readings from (``[web] readings``),
    or None for the collector's file; :class:`WebUnavailable` when the file asks for a
    server it does not configure."""
    config = collector.config
    postgres: Any = config.sinks.get("postgres")
    try:
        on_server = readings_on_server(
            config.web, file_keeps_readings=config.keep_readings, has_postgres=postgres is not None
        )
    except ValueError as exc:
        raise WebUnavailable(f"{config.path}: web.readings: {exc}") from None
    return str(postgres.dsn) if on_server else None


def _blocks_in_file(path: Path) -> None:
    """The per-block extremes in the collector's file (once; its writer waits meanwhile)."""
    began = time.monotonic()
    conn = sqlite3.connect(path, isolation_level=None, timeout=60.0)
    try:
        if blocks.install_sqlite(conn):
            log.info("dashboard: long-range extremes made in %.1f s", time.monotonic() - began)
    except sqlite3.Error as exc:  # the dashboard reads the rows instead (slower)
        log.warning("dashboard: no long-range extremes in %s: %s", path, exc)
    finally:
        conn.close()


async def _blocks_on_server(dsn: str) -> None:
    """The per-block extremes on the server, tried until made (or the collector stops)."""
    import psycopg

    def once() -> bool:
        """Made, there already, or never (a hypertable): True; no ``readings`` yet: False."""
        with psycopg.connect(dsn, autocommit=True, connect_timeout=10) as conn:
            blocks.install_postgres(conn)
            row = conn.execute("SELECT to_regclass('readings')").fetchone()
            return row is not None and row[0] is not None

    while True:
        try:
            if await asyncio.to_thread(once):
                return
        except psycopg.Error as exc:
            log.warning("dashboard: long-range extremes not made on the server yet: %s", exc)
        await asyncio.sleep(BLOCKS_RETRY_S)


def _report(task: asyncio.Task[None]) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.warning("the dashboard stopped: %s", task.exception())


async def collect_with_dashboard(
    config_path: Path,
    stop: asyncio.Event,
    on_web: Callable[[str, int], None] | None = None,
    poll_interval: float = 1.0,
) -> None:
    """Load the collector's configuration file, open its store and run it with the
    dashboard until ``stop`` (what ``make demo`` runs). Raises ``ConfigError``,
    ``StoreError`` or :class:`WebUnavailable`."""
    collector = Collector(load_config(config_path))
    try:
        collector.open()
    except BaseException:
        await collector.close()
        raise
    await run_collector(collector, stop, on_web=on_web, poll_interval=poll_interval)
