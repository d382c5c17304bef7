"""``sondalog collect FILE.toml``: run the collector until stopped (parsing only; the work is
in :mod:`sondalog.collect.runner`).

SIGHUP reads the file again and takes its sources (:mod:`sondalog.collect.reload`); a file
that does not load is logged and the running configuration kept.

Exit status: 0 stopped by SIGINT/SIGTERM (or ``--once`` done), 1 ``--once`` and a source
failed, 2 a configuration error (``FILE:LINE: field: message``) or a store that cannot be used.
"""

from __future__ import annotations

import asyncio
import signal
from pathlib import Path

import click

from sondalog.app.collector import WebUnavailable, run_collector
from sondalog.cli.common import Refused
from sondalog.collect.config import load_config
from sondalog.collect.reload import reloading
from sondalog.collect.runner import Collector
from sondalog.collect.sinks import build_sinks
from sondalog.collect.store_sqlite import SqliteStore, StoreError
from sondalog.config import ConfigError
from sondalog.io.loop import run as run_loop
from sondalog.io.loop import stop_on_signals

#: Seconds a stop waits for a reload under way (it waits for a stopped source's contact).
RELOAD_STOP = 10.0


@click.command()
@click.argument("config_file", metavar="FILE.toml", type=click.Path(path_type=Path))
@click.option("--once", is_flag=True, help="Contact every source once, then exit.")
@click.option(
    "--check",
    is_flag=True,
    help="Only check the configuration file (and the sink tables and the store, as a start would).",
)
def collect(config_file: Path, once: bool, check: bool) -> None:
    """Collect readings from loggers and buses into SQLite (and PostgreSQL, MQTT).

    Runs until SIGINT or SIGTERM, serving the dashboard (default http://127.0.0.1:8080/,
    the [web] table); SIGHUP reads the file again and takes its [[source]] list. The
    configuration is described in docs/collector.md.
    """
    try:
        config = load_config(config_file)
    except ConfigError as exc:
        raise Refused(str(exc)) from None
    if check:
        try:
            build_sinks(config.sinks)
            SqliteStore(config.store).check_sync()
        except StoreError as exc:
            raise Refused(str(exc)) from None
        click.echo(f"{config_file}: {len(config.sources)} sources, store {config.store}")
        return
    collector = Collector(config)
    try:
        collector.open()
    except StoreError as exc:
        raise Refused(str(exc)) from None
    try:
        run_loop(_run(collector, config_file, once))  # uvloop when installed (sondalog[fast])
    except WebUnavailable as exc:
        collector.store.close_sync()
        raise Refused(f"{config_file}: web.listen: {exc}") from None
    if once and collector.failing:
        raise click.ClickException(f"sources failed: {', '.join(sorted(collector.failing))}")


async def _run(collector: Collector, config_file: Path, once: bool) -> None:
    stop = stop_on_signals()

    def listening(host: str, port: int) -> None:
        click.echo(f"dashboard on http://{host}:{port}/", err=True)

    wake = asyncio.Event()
    reloads = None
    if not once:
        asyncio.get_running_loop().add_signal_handler(signal.SIGHUP, wake.set)
        reloads = asyncio.create_task(reloading(collector, config_file, wake), name="reload")
    try:
        await run_collector(collector, stop, once=once, on_web=listening)
    finally:
        if reloads is not None:  # (bounded: a reload waits for a contact under way)
            reloads.cancel()
            await asyncio.wait({reloads}, timeout=RELOAD_STOP)
