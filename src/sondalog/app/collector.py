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
server). The sinks keep the per-block extremes of its long ranges for every batch
(:mod:`sondalog.collect.blocks_sql`); beside it a task fills those of the rows stored before
(:mod:`sondalog.collect.blocks_fill`, a day at a time, in the background).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sondalog.collect.alarm_loop import alarm_store
from sondalog.collect.blocks_fill import fill_file, fill_server
from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector
from sondalog.collect.web_config import readings_on_server
from sondalog.web import create_app, serve
from sondalog.web.server import bind

log = logging.getLogger(__name__)


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
            fill = fill_file(collector.config.store) if dsn is None else fill_server(dsn)
            helpers.append(asyncio.create_task(fill, name="blocks"))
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
