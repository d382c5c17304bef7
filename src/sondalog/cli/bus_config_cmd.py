"""``sondalog bus config pull|plan|apply``: HCTMPS1 modules' settings as a file (issue 22).

Parsing only: the file is read by :mod:`sondalog.client.bus_config`, the bus work is
:mod:`sondalog.client.bus_config_run`. ``bus config URL ID --add-supervisor ...`` (one
module's settings as options, now ``bus config set``) keeps working: a first argument that
is no subcommand goes to ``set``. Exit codes: 2 for a bad file or usage (nothing written);
``plan`` 0 when nothing would change, 1 when something would, 2 on any error; ``apply`` 1
when a module was not applied.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import TypeVar

import click

from sondalog.cli.bus_master import run_master
from sondalog.cli.common import Refused
from sondalog.client.bus import DEFAULT_HOST_ID, BusMaster
from sondalog.client.bus_config import SettingsFile, load_settings, render
from sondalog.client.bus_config_run import ModulePlan, ModuleReport, apply, plan, pull
from sondalog.client.bus_links import BusUrlError, parse_bus_url
from sondalog.config import ConfigError
from sondalog.protocol.hctmps1_frames import is_valid_id
from sondalog.protocol.hctmps1_settings import FACTORY_PASSWORD, is_valid_password

T = TypeVar("T")


class _ConfigGroup(click.Group):
    """A group whose first argument, if no subcommand, is the ``set`` command's URL."""

    def resolve_command(
        self, ctx: click.Context, args: list[str]
    ) -> tuple[str | None, click.Command | None, list[str]]:
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            return "set", self.commands["set"], args
        return super().resolve_command(ctx, args)


def config_group(legacy: click.Command) -> click.Group:
    """``bus config``: pull, plan, apply, and ``legacy`` as ``set``."""
    group = _ConfigGroup(
        "config",
        help="A bus's module settings as a file: pull, plan, apply (docs/config-bus.md).\n\n"
        "bus config URL ID [options] (= bus config set) sets one module with options.",
        commands={"pull": pull_cmd, "plan": plan_cmd, "apply": apply_cmd, "set": legacy},
    )
    return group


def _url(ctx: click.Context, param: click.Parameter, value: str) -> str:
    try:
        parse_bus_url(value)
    except BusUrlError as exc:
        raise click.BadParameter(str(exc), ctx, param) from exc
    return value


def _ids(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> tuple[str, ...]:
    for value in values:
        if not is_valid_id(value):
            raise click.BadParameter(f"{value!r}: 1 to 8 of A-Z a-z 0-9 _ -", ctx, param)
    return values


def _host_id(ctx: click.Context, param: click.Parameter, value: str) -> str:
    return _ids(ctx, param, (value,))[0]


def _password(ctx: click.Context, param: click.Parameter, value: str) -> str:
    if not is_valid_password(value):
        raise click.BadParameter("1 to 16 printable characters without |, comma or space")
    return value


def _options(func: Callable[..., None]) -> Callable[..., None]:
    func = click.option(
        "--password",
        default=FACTORY_PASSWORD,
        show_default=True,
        envvar="SONDALOG_BUS_PASSWORD",
        callback=_password,
        help="Password for CONNECT (also $SONDALOG_BUS_PASSWORD); a module's own password"
        " in the file is tried first.",
    )(func)
    func = click.option(
        "--host-id",
        default=DEFAULT_HOST_ID,
        show_default=True,
        callback=_host_id,
        help="This host's own bus ID.",
    )(func)
    return click.option(
        "--timeout",
        type=click.FloatRange(min=0, min_open=True),
        help="Seconds to wait for a reply (default: from the baud rate).",
    )(func)


def _run(
    url: str, host_id: str, timeout: float | None, work: Callable[[BusMaster], Awaitable[T]]
) -> T:
    return run_master(url, host_id, timeout, work, lambda exc: f"{url}: {exc}: not an HCTMPS1 bus")


def _load(path: Path) -> SettingsFile:
    try:
        return load_settings(path)
    except ConfigError as exc:
        raise Refused(str(exc)) from exc


@click.command("pull")
@click.argument("url", callback=_url)
@click.option(
    "--address",
    "addresses",
    multiple=True,
    callback=_ids,
    help="A module to pull (repeatable; default: every module a scan finds).",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    help="File (default: stdout).",
)
@click.option("--all", "full", is_flag=True, help="Write factory values too.")
@_options
def pull_cmd(
    url: str,
    addresses: tuple[str, ...],
    output: Path | None,
    full: bool,
    password: str,
    host_id: str,
    timeout: float | None,
) -> None:
    """Read every module's settings into a TOML file (factory values left out).

    For each module: HELLO (its variant), CONNECT with --password, LISTSUP and LISTP,
    DISCONNECT, GETMODE. The password itself cannot be read and is never written.
    """
    states = _run(url, host_id, timeout, lambda m: pull(m, addresses, password))
    text = render(states, full=full)
    if output is None or str(output) == "-":
        click.echo(text, nl=False)
        return
    _write(output, text)
    click.echo(f"{len(states)} modules pulled into {output}", err=True)


def _write(path: Path, text: str) -> None:
    """Replace ``path`` whole (a temporary file renamed over it)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=".pull-")
    try:
        with os.fdopen(fd, "w") as out:
            out.write(text)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _show_plan(plans: list[ModulePlan]) -> tuple[int, int, list[str]]:
    """Print the plan; (settings to change, modules unchanged, errors)."""
    changes, unchanged, errors = 0, 0, []
    for mp in plans:
        if mp.refused is not None or mp.failure is not None:
            errors.append(mp.refused or mp.failure or "")
            continue
        for change in mp.changes:
            click.echo(f"{mp.label}: {change}")
        changes += len(mp.changes)
        if not mp.changes:
            unchanged += 1
            click.echo(f"{mp.label}: unchanged")
    return changes, unchanged, errors


@click.command("plan")
@click.argument("url", callback=_url)
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@_options
def plan_cmd(url: str, file: Path, password: str, host_id: str, timeout: float | None) -> None:
    """Show what apply would change; exit 0 nothing, 1 something, 2 an error.

    Each module of FILE is looked for at its address, else at its "was"; nothing is
    written. An error (a bad file, a module that does not answer, a wrong password, another
    variant) is named with the file's line and field.
    """
    settings = _load(file)
    try:
        plans = _run(url, host_id, timeout, lambda m: plan(m, settings, password))
    except click.ClickException as exc:
        raise Refused(exc.message) from exc
    changes, unchanged, errors = _show_plan(plans)
    for error in errors:
        click.echo(f"Error: {error}", err=True)
    if errors:
        sys.exit(2)
    touched = len(plans) - unchanged
    click.echo(
        f"plan: {_count(changes, 'setting')} to change on {_count(touched, 'module')},"
        f" {unchanged} unchanged"
    )
    sys.exit(1 if changes else 0)


@click.command("apply")
@click.argument("url", callback=_url)
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--yes", is_flag=True, help="Apply without asking.")
@_options
def apply_cmd(
    url: str, file: Path, yes: bool, password: str, host_id: str, timeout: float | None
) -> None:
    """Write only the differences, each read back; a refusal stops that module.

    Per module, inside <connect>: the symbol, the supervisors (deletions first), the
    password, the address last; then SAVEEE, REINIT and everything read back at the new
    address; autonomous mode after that. A refusal stops the module and REINIT gives back
    its saved settings; the other modules are still applied (exit 1 if one failed). Shows
    the plan and asks first, unless --yes.
    """
    settings = _load(file)

    async def work(master: BusMaster) -> list[ModuleReport] | None:
        plans = await plan(master, settings, password)
        refused = [mp.refused for mp in plans if mp.refused is not None]
        if refused:
            raise Refused("\n".join([*refused, "nothing was written"]))
        if not any(mp.changes or mp.failure for mp in plans):
            click.echo("nothing to change")
            return None
        if not yes and any(mp.changes for mp in plans):
            for error in _show_plan(plans)[2]:
                click.echo(f"Error: {error}", err=True)
            if not click.confirm("Apply these changes?"):
                raise click.ClickException("not applied")
        return await apply(master, plans, password)

    reports = _run(url, host_id, timeout, work)
    if reports is None:
        return
    for report in reports:
        _show_report(report)
    counts = {s: sum(r.status == s for r in reports) for s in ("changed", "unchanged", "failed")}
    click.echo("apply: " + ", ".join(f"{n} {s}" for s, n in counts.items()))
    if counts["failed"]:
        sys.exit(1)


def _count(n: int, what: str) -> str:
    return f"{n} {what}" if n == 1 else f"{n} {what}s"


def _show_report(report: ModuleReport) -> None:
    label = report.label
    if report.status == "unchanged":
        click.echo(f"{label}: unchanged")
    if report.failure is not None:
        click.echo(f"{label}: FAILED {report.failure}")
        for change in report.not_applied:
            click.echo(f"{label}: not applied {change}")
    eeprom = [c for c in report.applied if c.setting != "autonomous"]
    for change in eeprom:
        click.echo(f"{label}: applied {change}")
    for note in report.notes:
        click.echo(f"{label}: {note}")
    for change in report.applied[len(eeprom) :]:
        click.echo(f"{label}: applied {change}")
