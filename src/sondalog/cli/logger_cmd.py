"""``sondalog logger ...``: serve a virtual ALA1 data logger (parsing only; the work is in
:mod:`sondalog.app.logger`)."""

from __future__ import annotations

import functools
import sys
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path

import click
from serial import SerialException

from sondalog.app.logger import (
    IdentityConflict,
    Logger,
    logger_hardware,
    protocol_version,
    protocol_versions,
    serve_until,
    start_logger,
    valid_serial_number,
)
from sondalog.cli.common import (
    Refused,
    allow_remote_option,
    format_address,
    listen_option,
    speed_option,
)
from sondalog.config import ConfigError
from sondalog.io import loop as serve_loop
from sondalog.io.clock import make_clock
from sondalog.io.tcp import DEFAULT_PORT


@click.group()
def logger() -> None:
    """Virtual ALA1 data loggers."""


@logger.command()
@allow_remote_option
@click.option(
    "--listen",
    metavar="HOST:PORT",
    default=f"127.0.0.1:{DEFAULT_PORT}",
    callback=listen_option,
    show_default=True,
    help="Address to accept TCP connections on; port 0 picks a free port.",
)
@click.option(
    "--state",
    "state_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("state/logger"),
    show_default=True,
    help="State directory (non-volatile memory); created when missing.",
)
@click.option(
    "--protocol",
    type=click.Choice(protocol_versions()),
    default=None,
    help="Protocol version of a new logger (default 2.10); fixed once the state exists.",
)
@click.option(
    "--serial-number",
    default=None,
    help="Serial number (i snumber) of a new logger (default 000001); fixed once created.",
)
@speed_option("the module clock")
@click.option(
    "--site",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Site file (TOML) describing the simulated sensors (docs/simulation.md).",
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
    "--serial",
    "serials",
    metavar="DEVICE",
    multiple=True,
    help="Also serve on a real serial port, 8N1 at com speed (repeatable).",
)
@click.option(
    "--line-rate",
    is_flag=True,
    help="Pace TCP answers at com speed too, as on a serial line (pty and serial always are).",
)
def serve(
    listen: tuple[str, int],
    state_dir: Path,
    protocol: str | None,
    serial_number: str | None,
    speed: float,
    site: Path | None,
    ptys: tuple[Path, ...],
    serials: tuple[str, ...],
    line_rate: bool,
) -> None:
    """Serve one virtual ALA1 logger over TCP (§6.11.5.2.4: port 10001), ptys and serial ports.

    Prints "listening on HOST:PORT" once connections are accepted, then one line per pty
    ("pty PATH -> /dev/pts/N") and per serial port ("serial DEVICE"). Each line has its own
    line state; pty and serial lines are paced at com speed (§6.11.2). SIGINT or SIGTERM stop
    it cleanly and remove the pty symlinks.
    """
    if serial_number is not None and not valid_serial_number(serial_number):
        raise click.BadParameter(
            "1 to 32 printable ASCII characters without spaces", param_hint="--serial-number"
        )
    version = protocol_version(protocol)
    clock = make_clock(speed)
    try:
        hardware = logger_hardware(site, clock.now(), clock.speed)
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    lines = _Lines(ptys, serials, line_rate)
    start = functools.partial(
        start_logger,
        state_dir,
        clock,
        listen,
        version,
        serial_number,
        hardware=hardware,
        ptys=lines.ptys,
        serials=lines.serials,
        line_rate=lines.line_rate,
    )
    try:
        serve_loop.run(_serve(start, lines))
    except IdentityConflict as exc:
        raise Refused(str(exc)) from exc
    except _LineError as exc:
        raise click.ClickException(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(f"cannot serve on {format_address(*listen)}: {exc}") from exc


class _LineError(Exception):
    """A pty or serial line could not be opened."""


@dataclass(frozen=True)
class _Lines:
    ptys: tuple[Path, ...] = ()
    serials: tuple[str, ...] = ()
    line_rate: bool = False


async def _serve(start: Callable[..., Awaitable[Logger]], lines: _Lines) -> None:
    """Start the logger (``start(on_listening=...)``) and serve it until a signal."""
    stop = serve_loop.stop_on_signals()

    def announce(host: str, port: int) -> None:
        sys.stdout.write(f"listening on {format_address(host, port)}\n")
        sys.stdout.flush()

    try:
        running = await start(on_listening=announce)
    except (OSError, SerialException) as exc:
        if isinstance(exc, OSError) and not lines.ptys and not lines.serials:
            raise
        raise _LineError(f"cannot open the lines: {exc}") from exc
    for pty in running.ptys:
        sys.stdout.write(f"pty {pty.link} -> {pty.device}\n")
    for port in running.serials:
        sys.stdout.write(f"serial {port.device} at {port.baud} baud\n")
    sys.stdout.flush()
    await serve_until(stop, running)
