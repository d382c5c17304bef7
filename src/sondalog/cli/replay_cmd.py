"""``sondalog logger replay TRACE``: serve a recorded line back (parsing and printing only; the
work is in :mod:`sondalog.app.replay`)."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import click

from sondalog.app.replay import Replay, TraceError, load_replay, start_replay
from sondalog.cli.common import allow_remote_option, format_address, listen_option
from sondalog.io import loop as serve_loop
from sondalog.protocol.replay import Deviation, ReplayDevice


@click.command()
@click.argument("trace", type=click.Path(dir_okay=False, path_type=Path))
@allow_remote_option
@click.option(
    "--listen",
    metavar="HOST:PORT",
    default="127.0.0.1:10001",
    callback=listen_option,
    show_default=True,
    help="Address to accept TCP connections on; port 0 picks a free port.",
)
@click.option(
    "--pty",
    "ptys",
    metavar="PATH",
    multiple=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Also serve on a pseudo-terminal reachable through the symlink PATH (repeatable).",
)
@click.option(
    "--lenient",
    is_flag=True,
    help="Answer by command text in any order; unknown commands get the ERROR response.",
)
@click.option(
    "--once",
    is_flag=True,
    help="Stop when the first connection closes; exit 1 if the host deviated.",
)
def replay(
    trace: Path, listen: tuple[str, int], ptys: tuple[Path, ...], lenient: bool, once: bool
) -> None:
    """Serve a recorded line (a trace written by term) back as a device.

    Strict (the default): the host must send the recorded commands in order; anything else
    gets the error response (the line, then ERROR) and is reported on stderr with what the
    recording expected. Lenient:
    each command is answered by its text, in any order. Prints "listening on HOST:PORT"
    once connections are accepted; at the end, one summary line on stderr. Exit status 1
    when the host deviated from the recording (docs/testing.md).
    """
    try:
        device = load_replay(trace, lenient=lenient)
    except TraceError as exc:
        click.echo(f"Error: {exc}", err=True)
        sys.exit(2)
    except OSError as exc:
        raise click.BadParameter(f"cannot read {trace}: {exc.strerror or exc}") from exc
    try:
        served = serve_loop.run(_serve(device, listen, ptys, once))
    except OSError as exc:
        raise click.ClickException(f"cannot serve on {format_address(*listen)}: {exc}") from exc
    click.echo(served.summary(), err=True)
    sys.exit(1 if device.deviation_count else 0)


def _report(deviation: Deviation) -> None:
    click.echo(f"deviation: {deviation.describe()}", err=True)


async def _serve(
    device: ReplayDevice, listen: tuple[str, int], ptys: tuple[Path, ...], once: bool
) -> Replay:
    stop = serve_loop.stop_on_signals()
    served = await start_replay(device, listen, ptys=ptys, on_deviation=_report)
    sys.stdout.write(f"listening on {format_address(*served.address)}\n")
    for pty in served.ptys:
        sys.stdout.write(f"pty {pty.link} -> {pty.device}\n")
    sys.stdout.flush()
    try:
        if once:
            await _first_of(stop, served)
        else:
            await stop.wait()
    finally:
        await served.close()
    return served


async def _first_of(stop: asyncio.Event, served: Replay) -> None:
    waits = {asyncio.ensure_future(stop.wait()), asyncio.ensure_future(served.closed_lines.wait())}
    try:
        await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in waits:
            task.cancel()
