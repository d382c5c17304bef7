"""``sondalog serve SITE.toml``: serve everything a site file describes (parsing only)."""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import click

from sondalog.cli.common import (
    Refused,
    allow_remote_site_option,
    is_loopback,
    parse_listen,
    refuses_remote,
    speed_option,
)
from sondalog.io import loop as serve_loop

#: The environment variable the control API's token comes from (kept off the command line).
CONTROL_TOKEN_ENV = "SONDALOG_CONTROL_TOKEN"
_TOKEN = r"[A-Za-z0-9._~+/=-]{16,256}"


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
@click.option(
    "--control",
    metavar="HOST:PORT",
    default=None,
    help="Serve the control API there: inputs, faults, time, snapshots (docs/control.md). "
    f"Beyond loopback it needs --allow-remote and a token in ${CONTROL_TOKEN_ENV}.",
)
@click.option(
    "--scenario",
    "scenario",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Run the [[scenario]] entries of this file instead of the site file's own "
    "(docs/control.md).",
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
    control: str | None,
    scenario: Path | None,
    check: bool,
) -> None:
    """Serve the loggers, buses and mail hub that the site file SITE describes.

    Prints one line per part once it accepts connections (for example
    "logger 000001 listening on 127.0.0.1:10001"). SIGINT or SIGTERM stop everything cleanly.
    See docs/architecture.md and docs/simulation.md for the site file.
    """
    from sondalog.app.site import load_site, with_scenario
    from sondalog.config import ConfigError

    try:
        plan = load_site(site)
        if scenario is not None:
            plan = with_scenario(plan, scenario)
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    for field, (host, _port) in plan.listens:
        if refuses_remote(ctx, host):
            raise Refused(
                f"{site}: {field}: {host} is reachable from other machines and the protocol "
                "has no authentication (docs/security.md); add --allow-remote to serve there"
            )
    control_at = _control_address(ctx, control, plan.listens) if control is not None else None
    token = os.environ.get(CONTROL_TOKEN_ENV) or None
    if check:
        steps = f", {len(plan.scenario)} scenario steps" if plan.scenario else ""
        click.echo(f"{site}: {len(plan.listens)} listening addresses, no clash{steps}")
        return
    state = state_dir if state_dir is not None else Path("state") / site.stem
    try:
        serve_loop.run(_serve(plan, state, speed, trace, control_at, token))
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(f"cannot serve {site}: {exc}") from exc


def _control_address(
    ctx: click.Context, value: str, listens: list[tuple[str, tuple[str, int]]]
) -> tuple[str, int]:
    """``--control HOST:PORT``: loopback, or beyond it with --allow-remote and a token."""
    try:
        host, port = parse_listen(value)
    except ValueError as exc:
        raise Refused(f"--control: {exc}") from exc
    token = os.environ.get(CONTROL_TOKEN_ENV)
    if token is not None and not re.fullmatch(_TOKEN, token):
        raise Refused(f"${CONTROL_TOKEN_ENV}: must be 16 to 256 letters, digits or ._~+/=-")
    if refuses_remote(ctx, host):
        raise Refused(
            f"--control: {host} is reachable from other machines; add --allow-remote and set "
            f"a token in ${CONTROL_TOKEN_ENV} to serve the control API there"
        )
    if not is_loopback(host) and token is None:
        raise Refused(
            f"--control: refusing to serve the control API on {host} without a token: set "
            f"${CONTROL_TOKEN_ENV} (requests then need 'Authorization: Bearer <token>')"
        )
    for field, (other_host, other_port) in listens:
        if port and port == other_port and host in (other_host, "0.0.0.0", "::"):
            raise Refused(f"--control: port {port} is already used by {field}")
    return host, port


async def _serve(
    plan: object,
    state: Path,
    speed: float,
    trace: Path | None = None,
    control: tuple[str, int] | None = None,
    token: str | None = None,
) -> None:
    from sondalog.app.control_api import start_control
    from sondalog.app.scenario_run import site_control
    from sondalog.app.serve import start_site
    from sondalog.app.site import SitePlan
    from sondalog.config.address import format_address
    from sondalog.io.clock import Clock, make_clock
    from sondalog.io.clock_control import ControlledClock

    assert isinstance(plan, SitePlan)
    stop = serve_loop.stop_on_signals()

    def announce(line: str) -> None:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()

    clock: Clock = ControlledClock(speed) if control is not None else make_clock(speed)
    running = await start_site(plan, state, clock, announce, trace)
    server = controller = None
    try:
        if control is not None or plan.scenario:
            controller = site_control(running, clock, plan.scenario, announce)
        if control is not None and controller is not None:
            server = await start_control(controller, clock, *control, token=token)
            announce(f"control API on http://{format_address(*server.address)}")
        await stop.wait()
    finally:
        if server is not None:
            await server.stop()  # (and its controller)
        elif controller is not None:
            await controller.close()
        await running.close()
