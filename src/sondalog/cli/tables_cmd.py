"""``sondalog logger tables push|pull|check``: conversion tables on a logger (§6.16, §10).

Parsing only; the work is in :mod:`sondalog.client.tables`.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable, Iterator
from pathlib import Path
from typing import TypeVar

import click
from rich.console import Console
from rich.progress import (
    BarColumn,
    DownloadColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeRemainingColumn,
    TransferSpeedColumn,
)

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ClientError
from sondalog.client.tables import TableProblem, explain, pull, push, read_folder

T = TypeVar("T")
_err = Console(stderr=True)


def _run(url: str, work: Callable[[Ala1Client], Awaitable[T]], timeout: float) -> T:
    async def main() -> T:
        try:
            client = await Ala1Client.connect(url, timeout=timeout)
        except ValueError as exc:
            raise click.UsageError(str(exc)) from exc
        try:
            return await work(client)
        finally:
            await client.close()

    try:
        return asyncio.run(main())
    except (ClientError, OSError) as exc:
        raise click.ClickException(str(exc)) from exc


@contextlib.contextmanager
def _progress() -> Iterator[Callable[[str, int, int], None] | None]:
    """A ``progress(phase, done, total)`` callback with one bar per phase (bytes on the wire,
    total and time left when known) on stderr, kept once done; None when stderr is not a
    terminal: nothing is written there then, not even the blank line a transient bar leaves."""
    if not _err.is_terminal:
        yield None
        return
    with Progress(
        TextColumn("{task.description:<13}"),
        BarColumn(),
        DownloadColumn(),
        TransferSpeedColumn(),
        TimeRemainingColumn(),
        console=_err,
    ) as bar:
        yield _phases(bar)


def _phases(bar: Progress) -> Callable[[str, int, int], None]:
    """A ``progress(phase, done, total)`` callback that gives each phase its own bar."""
    tasks: dict[str, TaskID] = {}

    def update(phase: str, done: int, total: int) -> None:
        if phase not in tasks:
            tasks[phase] = bar.add_task(phase, total=total or None)
        bar.update(tasks[phase], completed=done, total=total or None)

    return update


@click.group()
def tables() -> None:
    """Conversion tables of a logger (manual §10): push, pull, check."""


@tables.command("push")
@click.argument("folder", type=click.Path(path_type=Path))
@click.argument("url")
@click.option("--timeout", type=float, default=5.0, show_default=True, help="Answer timeout.")
def push_cmd(folder: Path, url: str, timeout: float) -> None:
    """Check the tables in FOLDER, upload them to the logger at URL by XMODEM, verify.

    Every regular file of FOLDER is a table named after the file (without its extension).
    """
    try:
        found = read_folder(folder)
    except TableProblem as exc:
        for problem in exc.problems:
            _err.print(f"[red]error[/red]: {problem}", highlight=False)
        raise SystemExit(2) from exc

    async def work(client: Ala1Client) -> tuple[bytes, bytes]:
        with _progress() as progress:
            return await push(client, found, progress)

    try:
        listing, data = _run(url, work, timeout)
    except TableProblem as exc:
        for problem in exc.problems:
            _err.print(f"[red]error[/red]: {problem}", highlight=False)
        raise SystemExit(2) from exc
    click.echo(
        f"pushed {len(found)} tables ({len(listing)} bytes list, {len(data)} bytes data), verified"
    )


@tables.command("pull")
@click.argument("url")
@click.argument("folder", type=click.Path(file_okay=False, path_type=Path))
@click.option("--timeout", type=float, default=5.0, show_default=True, help="Answer timeout.")
def pull_cmd(url: str, folder: Path, timeout: float) -> None:
    """Download the tables of the logger at URL into FOLDER (one NAME.txt per table)."""

    async def work(client: Ala1Client) -> dict[str, bytes]:
        with _progress() as progress:
            return await pull(client, progress)

    found = _run(url, work, timeout)
    folder.mkdir(parents=True, exist_ok=True)
    for name, body in found.items():
        (folder / f"{name}.txt").write_bytes(body)
    click.echo(f"pulled {len(found)} tables into {folder}")


@tables.command("check")
@click.argument("url")
@click.option("--timeout", type=float, default=5.0, show_default=True, help="Answer timeout.")
def check_cmd(url: str, timeout: float) -> None:
    """Tell, for every channel of the logger at URL that names a table, whether it is usable
    (a missing or malformed table gives the channel no value, spec notes §7)."""
    report = _run(url, explain, timeout)
    for line in report or ["no channel names a table"]:
        click.echo(line)
    if any(": no value:" in line for line in report):
        raise SystemExit(1)
