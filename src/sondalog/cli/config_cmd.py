"""``sondalog logger config pull|plan|apply``: a logger's whole configuration as a file
(docs/config.md). Parsing only; the work is in :mod:`sondalog.client.station_apply` and
:mod:`sondalog.client.station_fleet`.

Exit codes: ``plan`` 0 when nothing would change, 1 when something would, 2 on an error;
``pull`` and ``apply`` 0, or 2 on an error (for a fleet: when any logger failed).
"""

from __future__ import annotations

import asyncio
import sys
from collections.abc import Coroutine
from pathlib import Path
from typing import Any, TypeVar

import click

from sondalog.app.explain import explain as explain_line
from sondalog.cli.common import Refused
from sondalog.client.ala1_codec import ClientError
from sondalog.client.phone import PhoneApiError
from sondalog.client.station_apply import Outcome, Plan, apply, make_plan, pull
from sondalog.client.station_apply import Refused as StationRefused
from sondalog.client.station_fleet import Result, Target, read_file, run_fleet, summary, writes
from sondalog.client.station_sms import apply_by_sms
from sondalog.config import ConfigError
from sondalog.io.private import open_private

T = TypeVar("T")


def _explain(line: str, version: str) -> str:
    return explain_line(line, version).render()


def _run(work: Coroutine[Any, Any, T]) -> T:
    try:
        return asyncio.run(work)
    except StationRefused as exc:
        raise Refused("the station cannot be applied:\n  " + "\n  ".join(exc.problems)) from exc
    except ValueError as exc:  # a URL parse_url refuses
        raise Refused(str(exc)) from exc
    except (ClientError, OSError) as exc:
        raise Refused(str(exc)) from exc


def _targets(args: tuple[str, ...]) -> tuple[str | None, list[Target]]:
    if len(args) not in (1, 2):
        raise click.UsageError("expected [URL] FILE")
    url, path = (None, args[0]) if len(args) == 1 else args
    try:
        targets = read_file(Path(path))
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    fleet = targets[0].url is not None
    if not fleet and url is None:
        raise click.UsageError(f"{path} holds one logger without a url: give URL FILE")
    if fleet and url is not None:
        targets = [t for t in targets if t.url == url]
        if not targets:
            raise Refused(f"{path} has no [[logger]] with url = {url!r}")
    if not fleet:
        targets = [Target(url, targets[0].station)]
    return url, targets


@click.group()
def config() -> None:
    """A logger's whole configuration as a station file: pull, plan, apply.

    See docs/config.md."""


@config.command("pull")
@click.argument("url")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Station file to write; tables go to OUTPUT's name + .tables/.")  # fmt: skip
@click.option("--all", "all_values", is_flag=True, help="Also write settings at factory values.")
@click.option("--iaddress", default=None, help="The logger's i address, if it has one (§8.6.1).")
def pull_cmd(url: str, output: Path, all_values: bool, iaddress: str | None) -> None:
    """Read every setting of the logger at URL into a station file (TOML)."""
    folder = output.with_name(output.stem + ".tables")
    text, tables = _run(
        pull(url, all_values=all_values, iaddress=iaddress, tables_dir=f"{folder.name}/")
    )
    if tables:
        folder.mkdir(parents=True, exist_ok=True)
        for name, body in tables.items():
            (folder / f"{name}.txt").write_bytes(body)
    with open_private(output) as handle:  # it may hold mail passwords (§6.11.6.3)
        handle.write(text)
    where = f" and {len(tables)} tables in {folder}" if tables else ""
    click.echo(f"wrote {output}{where}")


def _print_plan(plan: Plan) -> None:
    for line in plan.lines():
        click.echo(f"  {line}")


@config.command("plan", context_settings={"ignore_unknown_options": False})
@click.argument("args", nargs=-1, metavar="[URL] FILE")
@click.option("--parallel", type=click.IntRange(1, 256), default=8, show_default=True,
              help="Loggers of a fleet file planned at once.")  # fmt: skip
@click.option("--iaddress", default=None, help="The logger's i address, if it has one (§8.6.1).")
def plan_cmd(args: tuple[str, ...], parallel: int, iaddress: str | None) -> None:
    """What apply would change on the logger at URL (or every logger of a fleet FILE).

    Exit 0: nothing would change; 1: something would; 2: an error."""
    url, targets = _targets(args)
    if targets[0].url is not None and url is None:
        results = _run(run_fleet(targets, None, parallel, lambda r: click.echo(r.line())))
        click.echo(summary(results))
        sys.exit(2 if _failed(results) else 1 if _changed(results) else 0)
    target = targets[0]
    assert target.url is not None
    plan = _run(make_plan(target.url, target.station, iaddress=iaddress))
    if plan.empty:
        for note in plan.notes:
            click.echo(note)
        click.echo(f"logger {plan.identity.serial}: nothing to change")
        sys.exit(0)
    click.echo(f"logger {plan.identity.serial} ({plan.identity.version}) would change:")
    _print_plan(plan)
    sys.exit(1)


def _failed(results: list[Result]) -> bool:
    return any(r.state == "failed" for r in results)


def _changed(results: list[Result]) -> bool:
    return any(r.state in ("changed", "would change") for r in results)


@config.command("apply")
@click.argument("args", nargs=-1, metavar="[URL] FILE")
@click.option("--yes", is_flag=True, help="Do not ask before writing.")
@click.option("--parallel", type=click.IntRange(1, 256), default=8, show_default=True,
              help="Loggers of a fleet file written at once.")  # fmt: skip
@click.option("--iaddress", default=None, help="The logger's i address, if it has one (§8.6.1).")
@click.option(
    "--via",
    type=click.Choice(["line", "sms"]),
    default="line",
    show_default=True,
    help="sms: the file's settings as SMS commands (URL gsm://API/NUMBER?from=PHONE).",
)
def apply_cmd(
    args: tuple[str, ...], yes: bool, parallel: int, iaddress: str | None, via: str
) -> None:
    """Write what differs to the logger at URL (or every logger of a fleet FILE), each write
    verified by reading it back; stops at the first refusal and says why.

    With --via sms, every setting the file gives is sent as SMS commands, each answer checked
    (no diff: SMS cannot read the whole configuration back)."""
    url, targets = _targets(args)
    if via == "sms":
        _apply_by_sms(url, targets, yes)
        return
    if targets[0].url is not None and url is None:
        if not yes:
            click.confirm(f"apply to {len(targets)} loggers?", abort=True)
        results = _run(run_fleet(targets, _explain, parallel, lambda r: click.echo(r.line())))
        click.echo(summary(results))
        sys.exit(2 if _failed(results) else 0)
    target = targets[0]
    assert target.url is not None
    if not yes:
        plan = _run(make_plan(target.url, target.station, iaddress=iaddress))
        if plan.empty:
            click.echo(f"logger {plan.identity.serial}: nothing to change")
            return
        click.echo(f"logger {plan.identity.serial} ({plan.identity.version}) will change:")
        _print_plan(plan)
        click.confirm("apply?", abort=True)
    outcome = _run(apply(target.url, target.station, _explain, iaddress=iaddress))
    _report(outcome)


def _report(outcome: Outcome) -> None:
    serial = outcome.plan.identity.serial
    for note in outcome.plan.notes:
        click.echo(note)
    if outcome.error is None and not outcome.applied:
        click.echo(f"logger {serial}: nothing to change")
        return
    for line in outcome.applied:
        click.echo(f"  applied: {line}")
    for line in outcome.warnings:
        click.echo(f"warning: {line}", err=True)
    if outcome.error is None:
        click.echo(f"logger {serial}: {writes(len(outcome.applied))} applied and verified")
        return
    click.echo(f"error: {outcome.error}", err=True)
    for line in outcome.not_applied:
        click.echo(f"  not applied: {line}", err=True)
    sys.exit(2)


def _apply_by_sms(url: str | None, targets: list[Target], yes: bool) -> None:
    if url is None or len(targets) != 1 or not url.lower().startswith("gsm://"):
        raise click.UsageError("--via sms takes one logger: gsm://API/NUMBER?from=PHONE FILE")
    if not yes:
        click.confirm(f"send the file's settings to {url} by SMS?", abort=True)
    try:
        outcome = apply_by_sms(url, targets[0].station, _explain, report=click.echo)
    except ConfigError as exc:
        raise Refused(str(exc)) from exc
    except (PhoneApiError, ValueError) as exc:
        raise Refused(str(exc)) from exc
    if outcome.error is None:
        click.echo(f"{writes(len(outcome.sent))} sent by SMS, every answer OK")
        return
    click.echo(f"error: {outcome.error}", err=True)
    for line in outcome.not_sent:
        click.echo(f"  not applied: {line}", err=True)
    sys.exit(2)
