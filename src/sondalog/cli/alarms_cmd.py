"""``sondalog alarms list|ack FILE.toml``: the collector's alarms (parsing only; the work is
in :mod:`sondalog.app.alarms`).

Exit status: 0 done, 2 a configuration error or an alarm that cannot be acknowledged.
"""

from __future__ import annotations

from pathlib import Path

import click

from sondalog.cli.common import Refused
from sondalog.config import ConfigError

_FILE = click.argument("config_file", metavar="FILE.toml", type=click.Path(path_type=Path))


@click.group()
def alarms() -> None:
    """The collector's alarms: list them, acknowledge one."""


@alarms.command("list")
@_FILE
@click.option("--all", "every", is_flag=True, help="Every alarm and the recent history.")
def list_cmd(config_file: Path, every: bool) -> None:
    """Active alarms of the collector of FILE.toml: id, state, since, value, rule, subject."""
    from sondalog.app.alarms import list_alarms, table_lines

    try:
        listing = list_alarms(config_file, every)
    except ConfigError as exc:
        raise Refused(str(exc)) from None
    for line in table_lines(listing):
        click.echo(line)


@alarms.command("ack")
@_FILE
@click.argument("alarm_id", metavar="ID")
@click.option("--by", default=None, help="Who acknowledges (default: your user name).")
def ack_cmd(config_file: Path, alarm_id: str, by: str | None) -> None:
    """Acknowledge the raised alarm ID: no more repeats until it clears."""
    from sondalog.app.alarms import AlarmRefused, acknowledge

    try:
        record = acknowledge(config_file, alarm_id, by)
    except (ConfigError, AlarmRefused) as exc:
        raise Refused(str(exc)) from None
    click.echo(f"acknowledged {record.alarm}: {record.rule} / {record.subject}")
