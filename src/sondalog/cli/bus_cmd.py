"""``sondalog bus ...``: serve a virtual RS-485 bus of HCTMPS1 modules, and talk to one.

Parsing only (DESIGN.md point 7): the bus lives in :mod:`sondalog.world.bus` and
:mod:`sondalog.app.bus`, the host side in :mod:`sondalog.client.bus`. Bad input exits with
code 2, a bus that does not answer with 1.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TypeVar, cast

import click

from sondalog.app.bus import DEFAULT_PORT, BusServer, rs485_settings, start_bus_server
from sondalog.app.bus_explain import upper_case_hint, why_no_reply
from sondalog.cli.bus_config_cmd import config_group
from sondalog.cli.bus_master import run_master
from sondalog.cli.common import (
    Refused,
    allow_remote_option,
    format_address,
    listen_option,
    speed_option,
)
from sondalog.client.bus import DEFAULT_HOST_ID, BusMaster
from sondalog.client.bus_actions import (
    ConnectRefused,
    ModuleSettings,
    configure_module,
    format_data,
    watch_modules,
)
from sondalog.client.bus_errors import NoReply
from sondalog.client.bus_links import BusUrlError, parse_bus_url
from sondalog.config import ConfigError
from sondalog.io import loop as serve_loop
from sondalog.io.clock import make_clock
from sondalog.io.rs485 import MODES, Mode, Rs485Error
from sondalog.protocol.hctmps1_frames import BROADCAST, FrameError, is_valid_id

T = TypeVar("T")
log = logging.getLogger(__name__)


def _url(ctx: click.Context, param: click.Parameter, value: str) -> str:
    try:
        parse_bus_url(value)
    except BusUrlError as exc:
        raise click.BadParameter(str(exc), ctx, param) from exc
    return value


def _module_id(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    if value is not None and not is_valid_id(value):
        raise click.BadParameter(f"{value!r}: 1 to 8 of A-Z a-z 0-9 _ -", ctx, param)
    return value


def _module_ids(
    ctx: click.Context, param: click.Parameter, values: tuple[str, ...]
) -> tuple[str, ...]:
    for value in values:
        _module_id(ctx, param, value)
    return values


@click.group()
def bus() -> None:
    """Virtual RS-485 bus with HCTMPS1 sensor servers, and a bus master."""


@bus.command()
@allow_remote_option
@click.option(
    "--listen",
    metavar="HOST:PORT",
    default=f"127.0.0.1:{DEFAULT_PORT}",
    callback=listen_option,
    show_default=True,
    help="TCP gateway address; port 0 picks a free port.",
)
@click.option("--pty", "pty_link", type=click.Path(path_type=Path), help="Symlink to a pty.")
@click.option("--serial", "serial_device", metavar="DEVICE", help="Attach a real serial port.")
@click.option(
    "--rs485",
    type=click.Choice(MODES),
    help="The serial port is an RS-485 adapter: how its driver is switched (docs/linux-board.md).",
)
@click.option(
    "--state",
    "state_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("state/bus"),
    show_default=True,
    help="State directory (the modules' EEPROM); created when missing.",
)
@click.option(
    "--site",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Site file (TOML) naming the modules; default: T1 (temp) and H1 (hum).",
)
@click.option("--baud", type=click.IntRange(min=1), help="Bus speed (default 9600).")
@speed_option("the bus clock")
@click.option(
    "--noise",
    type=click.FloatRange(min=0, max=1, max_open=True),
    help="Bit error rate injected on the line (tests).",
)
@click.option("--seed", type=int, help="Seed of the random reply delays and the noise.")
def serve(
    listen: tuple[str, int],
    pty_link: Path | None,
    serial_device: str | None,
    rs485: str | None,
    state_dir: Path,
    site: Path | None,
    baud: int | None,
    speed: float,
    noise: float | None,
    seed: int | None,
) -> None:
    """Run a virtual RS-485 bus (hctmps1.md §1, §2).

    Prints "listening on HOST:PORT" once ready. SIGINT or SIGTERM stop it cleanly.
    """
    if rs485 is not None and serial_device is None:
        raise click.UsageError("--rs485 needs the adapter: --serial DEVICE")
    start = functools.partial(
        start_bus_server,
        make_clock(speed),
        listen,
        site=site,
        state_dir=state_dir,
        baud=baud,
        pty=pty_link,
        serial=serial_device,
        noise=noise,
        seed=seed,
        rs485=rs485_settings(cast(Mode, rs485)) if rs485 is not None else None,
    )
    try:
        serve_loop.run(_serve(start))
    except (ConfigError, FileExistsError, Rs485Error) as exc:
        raise Refused(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(f"cannot serve the bus: {exc}") from exc


async def _serve(start: Callable[[], Awaitable[BusServer]]) -> None:
    stop = serve_loop.stop_on_signals()
    running = await start()
    try:
        sys.stdout.write(f"listening on {format_address(*running.address)}\n")
        sys.stdout.flush()
        await stop.wait()
    finally:
        await running.close()


# -- host side --------------------------------------------------------------------------


def _master_options(func: Callable[..., None]) -> Callable[..., None]:
    func = click.option(
        "--host-id",
        default=DEFAULT_HOST_ID,
        show_default=True,
        callback=_module_id,
        help="This host's own bus ID.",
    )(func)
    func = click.option(
        "--timeout",
        type=click.FloatRange(min=0, min_open=True),
        help="Seconds to wait for a reply (default: from the baud rate).",
    )(func)
    return click.argument("url", callback=_url)(func)


def _run_master(
    url: str, host_id: str, timeout: float | None, work: Callable[[BusMaster], Awaitable[T]]
) -> T:
    return run_master(
        url,
        host_id,
        timeout,
        work,
        lambda exc: f"{url}: {exc}. Is this an ALA1 logger? Talk to it with: sondalog term {url}",
    )


@bus.command()
@_master_options
def scan(url: str, host_id: str, timeout: float | None) -> None:
    """Find every module on the bus (broadcast HELLO until no new one answers).

    Each round broadcasts HELLO and listens for the random reply delays of all modules
    (about 1.7 s at 9600 baud). On a terminal a progress line shows the rounds; -v logs one
    line per round. A peer that answers with something other than HCTMPS1 frames (an ALA1
    logger) is reported after the first round.
    """

    async def work(master: BusMaster) -> dict[str, str]:
        if not sys.stderr.isatty():
            return await master.scan(progress=_log_round)
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn

        with Progress(
            SpinnerColumn(),
            TextColumn("{task.description}"),
            console=Console(stderr=True),
            transient=True,
        ) as bar:
            task = bar.add_task("scanning: round 1 (HELLO to *)", total=None)

            def show(number: int, rounds: int, found: dict[str, str]) -> None:
                _log_round(number, rounds, found)
                names = ", ".join(found) or "none yet"
                bar.update(task, description=f"scanning: round {number + 1}, found {names}")

            return await master.scan(progress=show)

    found = _run_master(url, host_id, timeout, work)
    for module_id, hello in found.items():
        click.echo(f"{module_id:<8} {hello}")
    if not found:
        raise click.ClickException(
            f"no module answered HELLO at {url} (check the URL, the bus speed and the wiring)"
        )


def _log_round(number: int, rounds: int, found: dict[str, str]) -> None:
    log.info("scan round %d/%d: HELLO to *, modules so far: %s", number, rounds, found or "none")


@bus.command()
@_master_options
@click.argument("module_id", metavar="ID")
@click.argument("command", metavar="CMD")
@click.argument("param", metavar="[PARAM]", required=False)
def ask(
    url: str,
    host_id: str,
    timeout: float | None,
    module_id: str,
    command: str,
    param: str | None,
) -> None:
    """Send one command to module ID (* for broadcast) and print the reply.

    Commands are upper case (HELLO, PV, CONNECT 0000, LISTSUP, ...); the settings commands
    need CONNECT first, from the same --host-id.
    """
    if module_id != BROADCAST and not is_valid_id(module_id):
        raise Refused(f"ID {module_id!r}: 1 to 8 of A-Z a-z 0-9 _ -, or * for broadcast")
    body = command if param is None else f"{command}.{param}"
    if not command or "." in command or not body.isascii() or "|" in body:
        raise Refused(f"bad command {body!r}: printable ASCII without '|'")
    hint = upper_case_hint(command)
    if hint is not None:
        raise Refused(hint)

    async def work(master: BusMaster) -> list[str]:
        if module_id == BROADCAST:
            return [f"{f.src} {f.body}" for f in await master.broadcast(body)]
        if body == "REPLY":
            data = await master.reply(module_id)
            return ["RREPLY.NODATA" if data is None else f"RPV.{data.value} (to {data.addressee})"]
        try:
            reply = await master.command(module_id, command, param)
        except NoReply:
            if command != "HELLO":
                try:
                    await master.hello(module_id)
                except NoReply:
                    raise click.ClickException(
                        f"no reply from {module_id} to {command}, nor to HELLO: is {module_id}"
                        " on this bus? (bus scan lists the modules)"
                    ) from None
            raise click.ClickException(why_no_reply(module_id, command, host_id)) from None
        return [f"R{command}.{reply}"]

    try:
        lines = _run_master(url, host_id, timeout, work)
    except FrameError as exc:
        raise Refused(str(exc)) from exc
    for line in lines:
        click.echo(line)
    if not lines:
        raise click.ClickException("no reply")


@click.command("set")
@_master_options
@click.argument("module_id", metavar="ID", callback=_module_id)
@click.option("--password", default="0000", show_default=True, help="Password for CONNECT.")
@click.option("--set-id", "new_id", callback=_module_id, help="New module ID (SETMID).")
@click.option(
    "--add-supervisor", "add", multiple=True, callback=_module_ids, help="ADDSUP (repeatable)."
)
@click.option("--del-supervisor", "delete", multiple=True, callback=_module_ids, help="DELSUP.")
@click.option("--symbol", help="Symbol of the measured variable (ADDP).")
@click.option("--new-password", help="New password (NEWPW).")
@click.option("--save/--no-save", default=False, help="SAVEEE before DISCONNECT.")
def config(
    url: str,
    host_id: str,
    timeout: float | None,
    module_id: str,
    password: str,
    new_id: str | None,
    add: tuple[str, ...],
    delete: tuple[str, ...],
    symbol: str | None,
    new_password: str | None,
    save: bool,
) -> None:
    """Open <connect> on module ID, apply the settings, optionally SAVEEE, DISCONNECT."""

    settings = ModuleSettings(add, delete, symbol, new_password, new_id, save)

    async def work(m: BusMaster) -> list[str]:
        try:
            return await configure_module(m, module_id, password, settings)
        except ConnectRefused as exc:
            raise click.ClickException(str(exc)) from exc

    for line in _run_master(url, host_id, timeout, work):
        click.echo(line)


bus.add_command(config_group(config))  # bus config pull|plan|apply, and this one as set


@bus.command()
@_master_options
@click.option(
    "--module",
    "modules",
    multiple=True,
    callback=_module_ids,
    help="Module to watch (repeatable; default: every module a scan finds).",
)
@click.option("--count", type=click.IntRange(min=1), help="Stop after this many data frames.")
def watch(
    url: str, host_id: str, timeout: float | None, modules: tuple[str, ...], count: int | None
) -> None:
    """Turn on autonomous mode and print data frames as they arrive, with timestamps.

    Each module gets this host on its temporary distribution list (CSSERVON) and AUTOON; the
    host then grants REPLY round-robin. Ctrl-C (or --count) undoes both and stops.
    """

    async def work(m: BusMaster) -> None:
        targets = list(modules) or list(await m.scan())
        if not targets:
            raise click.ClickException("no module answered")
        click.echo(f"watching {', '.join(targets)}", err=True)
        seen = 0
        stream = watch_modules(m, targets, host_id)
        try:
            async for data in stream:
                click.echo(format_data(data))
                seen += 1
                if count is not None and seen >= count:
                    break
        finally:
            await stream.aclose()

    with contextlib.suppress(KeyboardInterrupt):
        _run_master(url, host_id, timeout, work)
