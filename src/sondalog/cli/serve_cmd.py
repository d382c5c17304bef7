"""``sondalog serve SITE.toml``: serve everything a site file describes (parsing only)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from sondalog.cli.common import (
    Refused,
    allow_remote_site_option,
    refuses_remote,
    speed_option,
)
from sondalog.io import loop as serve_loop


@click.command()
@click.argument("site", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--state",
    "state_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="State directory (non-volatile memories, mailboxes); default state/<site name>.",
)
@speed_option("the devices' clock")
@click.option(
    "--trace",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Record the line of the logger's GSM modem in this file (docs/gsm.md).",
)
@allow_remote_site_option
@click.option(
    "--check",
    is_flag=True,
    help="Only check the site file (every part, the files it names, the ports), then exit.",
)
@click.pass_context
def serve(
    ctx: click.Context,
    site: Path,
    state_dir: Path | None,
    speed: float,
    trace: Path | None,
    check: bool,
) -> None:
    """Serve the loggers, buses and mail hub that the site file SITE describes.

    Prints one line per part once it accepts connections (for example
    "logger 000001 listening on 127.0.0.1:10001"). SIGINT or SIGTERM stop everything cleanly.
    See docs/architecture.md and docs/simulation.md for the site file.
    """
    from sondalog.app.site import load_site
    from sondalog.config import ConfigError

    try:
        plan = load_site(site)
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    for field, (host, _port) in plan.listens:
        if refuses_remote(ctx, host):
            raise Refused(
                f"{site}: {field}: {host} is reachable from other machines and the protocol "
                "has no authentication (docs/security.md); add --allow-remote to serve there"
            )
    if check:
        click.echo(f"{site}: {len(plan.listens)} listening addresses, no clash")
        return
    state = state_dir if state_dir is not None else Path("state") / site.stem
    try:
        serve_loop.run(_serve(plan, state, speed, trace))
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(f"cannot serve {site}: {exc}") from exc


async def _serve(plan: object, state: Path, speed: float, trace: Path | None = None) -> None:
    from sondalog.app.serve import start_site
    from sondalog.app.site import SitePlan
    from sondalog.io.clock import make_clock

    assert isinstance(plan, SitePlan)
    stop = serve_loop.stop_on_signals()

    def announce(line: str) -> None:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()

    running = await start_site(plan, state, make_clock(speed), announce, trace)
    try:
        await stop.wait()
    finally:
        await running.close()
