"""``sondalog logger download URL -o FILE``: fetch the new record rows into a file (parsing
and reporting only; the work is in :mod:`sondalog.collect.to_file`).

Exit status: 0 done, 1 the logger cannot be reached or its answers cannot be used, 2 bad
usage or a file that is not ours, 130 interrupted (the file is valid; run again to resume).
"""

from __future__ import annotations

import asyncio
import contextlib
import sys
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import click

from sondalog.cli.common import Refused
from sondalog.client import ClientError, parse_url
from sondalog.client.download import Chunk, DownloadError, Gap
from sondalog.collect.export import ExportError
from sondalog.collect.to_file import FileDownload, download_to_file


def _zone(ctx: click.Context, param: click.Parameter, value: str | None) -> ZoneInfo | None:
    if value is None:
        return None
    try:
        return ZoneInfo(value)
    except (ZoneInfoNotFoundError, ValueError):
        raise click.BadParameter(f"unknown time zone {value!r} (e.g. Europe/Prague)") from None


@click.command()
@click.argument("url")
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="File to append to: .csv, .jsonl or .parquet (created when missing).",
)
@click.option(
    "--tz",
    "zone",
    metavar="ZONE",
    callback=_zone,
    help="The logger's time zone (e.g. Europe/Prague, Etc/GMT-1): fills the utc column.",
)
@click.option(
    "--timeout",
    type=click.FloatRange(min=0.1),
    default=5.0,
    show_default=True,
    help="Seconds to wait for an answer (longer chunks get more).",
)
def download(url: str, output: Path, zone: ZoneInfo | None, timeout: float) -> None:
    """Download the record rows written since the last run into a file.

    The first run reads the whole record; each later run on the same file appends exactly the
    rows written since, resuming after the last row the file holds (never by the logger's
    last-read points). Every chunk is verified with crcsum and read again on a mismatch.
    """
    try:
        parse_url(url)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="URL") from None
    state = FileDownload(output)
    terminal = sys.stderr.isatty()
    progress = _progress() if terminal else None
    task: Any = None

    def on_chunk(done: FileDownload, chunk: Chunk) -> None:
        if progress is not None:
            progress.update(
                task,
                advance=len(chunk.rows),
                description=f"{done.rows} rows, {done.bytes / 1024:.0f} KiB",
            )

    def on_gap(gap: Gap) -> None:
        click.echo(f"warning: {gap.describe()}", err=True)

    try:
        with contextlib.nullcontext() if progress is None else progress:  # stops the progress
            if progress is not None:
                task = progress.add_task(f"downloading {url}", total=None)
            asyncio.run(
                download_to_file(
                    url,
                    output,
                    zone=zone,
                    timeout=timeout,
                    state=state,
                    on_chunk=on_chunk,
                    on_gap=on_gap,
                )
            )
    except KeyboardInterrupt:
        click.echo(
            f"interrupted: {state.rows} rows appended to {output}, which is valid; "
            "run again to resume",
            err=True,
        )
        sys.exit(130)
    except ExportError as exc:
        raise Refused(str(exc)) from None
    except (DownloadError, ClientError) as exc:
        raise click.ClickException(f"{url}: {exc} ({state.rows} rows appended before)") from None
    except OSError as exc:
        raise click.ClickException(
            f"cannot reach the logger at {url}: {exc.strerror or exc}"
        ) from None
    if state.repaired:
        click.echo(f"{output}: repaired {state.repaired}", err=True)
    if state.record_empty and state.resumed_after is not None:
        click.echo("warning: the logger's record is empty (cleared since the last run?)", err=True)
    if terminal:
        click.echo(_summary(state), err=True)


def _progress() -> Any:
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    return Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    )


def _summary(state: FileDownload) -> str:
    who = state.info.snumber if state.info else "?"
    text = f"logger {who}: {state.rows} new rows ({state.readings} readings) -> {state.path}"
    if state.cursor:
        text += f", last row {state.cursor}"
    if state.rereads:
        text += f", {state.rereads} chunks read again"
    if state.info is not None:
        text += f"; {state.info.clock.describe()}"
    return text
