"""Entry point of the ``sondalog`` console script.

Each command group lives in its own module (``logger_cmd``, ``term_cmd``, ``bus_cmd``) and is
registered here by name, so the groups can grow independently. Registration is lazy
(click's LazyGroup pattern, issue 11): a command's module is imported only when that command
runs, and ``sondalog --help`` lists the names with the short help kept here, importing none
of them (``tests/app/test_cli_lazy.py`` checks that the texts agree with the modules').
"""

from __future__ import annotations

import importlib
import logging
from dataclasses import dataclass

import click

from sondalog import __version__


@dataclass(frozen=True)
class LazyCommand:
    """Where a command lives, and the first paragraph of its help (for ``--help``)."""

    module: str
    attr: str
    help: str
    parent: str = ""  # "" for the root group, else the group it belongs to


#: Every command or group added to the root group, and the commands added to a group.
COMMANDS: dict[str, LazyCommand] = {
    "logger": LazyCommand("sondalog.cli.logger_cmd", "logger", "Virtual ALA1 data loggers."),
    "term": LazyCommand(
        "sondalog.cli.term_cmd",
        "term",
        "Talk to an ALA1 logger at URL (tcp://HOST:PORT, serial:///DEVICE?baud=9600).",
    ),
    "bus": LazyCommand(
        "sondalog.cli.bus_cmd",
        "bus",
        "Virtual RS-485 bus with HCTMPS1 sensor servers, and a bus master.",
    ),
    "serve": LazyCommand(
        "sondalog.cli.serve_cmd",
        "serve",
        "Serve the loggers, buses and mail hub that the site file SITE describes.",
    ),
    "collect": LazyCommand(
        "sondalog.cli.collect_cmd",
        "collect",
        "Collect readings from loggers and buses into SQLite (and PostgreSQL, MQTT).",
    ),
    "alarms": LazyCommand(
        "sondalog.cli.alarms_cmd",
        "alarms",
        "The collector's alarms: list them, acknowledge one.",
    ),
    "phone": LazyCommand(
        "sondalog.cli.phone_cmd",
        "phone",
        "Send and read SMS and place calls as a phone of a served GSM network.",
    ),
}
SUBCOMMANDS: dict[str, LazyCommand] = {
    "tables": LazyCommand(
        "sondalog.cli.tables_cmd",
        "tables",
        "Conversion tables of a logger (manual §10): push, pull, check.",
        "logger",
    ),
    "replay": LazyCommand(
        "sondalog.cli.replay_cmd",
        "replay",
        "Serve a recorded line (a trace written by term) back as a device.",
        "logger",
    ),
    "config": LazyCommand(
        "sondalog.cli.config_cmd",
        "config",
        "A logger's whole configuration as a station file: pull, plan, apply.",
        "logger",
    ),
    "download": LazyCommand(
        "sondalog.cli.download_cmd",
        "download",
        "Download the record rows written since the last run into a file.",
        "logger",
    ),
}


class LazyGroup(click.Group):
    """A group whose commands are imported when used; ``--help`` imports none of them."""

    lazy: dict[str, LazyCommand]

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        command = super().get_command(ctx, cmd_name)
        if command is not None or cmd_name not in self.lazy:
            return command
        command = load(self.lazy[cmd_name])
        if command is not None:
            self.add_command(command, cmd_name)
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The listing of ``--help``: loaded commands as click lists them, lazy ones from
        their stored help, with click's own truncation."""
        rows: list[tuple[str, click.Command]] = []
        for name in self.list_commands(ctx):
            command = self.commands.get(name)
            if command is None:
                command = click.Command(name, help=self.lazy[name].help)
            if not command.hidden:
                rows.append((name, command))
        if not rows:
            return
        limit = formatter.width - 6 - max(len(name) for name, _ in rows)
        with formatter.section("Commands"):
            formatter.write_dl([(name, cmd.get_short_help_str(limit)) for name, cmd in rows])


def _lazy_group(group: click.Group, lazy: dict[str, LazyCommand]) -> LazyGroup:
    """``group`` (built by its module with ``@click.group``) with lazy commands added."""
    copy = LazyGroup.__new__(LazyGroup)
    copy.__dict__.update(group.__dict__)
    copy.commands = dict(group.commands)
    copy.lazy = lazy
    return copy


def load(entry: LazyCommand) -> click.Command | None:
    """Import a command's module; None while that command group is not built yet."""
    try:
        module = importlib.import_module(entry.module)
    except ModuleNotFoundError as exc:
        if exc.name == entry.module:
            return None
        raise
    command: click.Command = getattr(module, entry.attr)
    name = next(n for n, e in {**COMMANDS, **SUBCOMMANDS}.items() if e is entry)
    children = {n: e for n, e in SUBCOMMANDS.items() if e.parent == name}
    if children and isinstance(command, click.Group):
        return _lazy_group(command, children)
    return command


@click.group(cls=LazyGroup)
@click.version_option(__version__, prog_name="sondalog")
@click.option("-v", "--verbose", count=True, help="More log output (repeat for debug).")
def cli(verbose: int) -> None:
    """sondalog: virtual ALA1 data loggers, HCTMPS1 sensor servers and host tools."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s %(message)s")


cli.lazy = COMMANDS


def main() -> None:
    from sondalog.io.loop import LoopChoiceError

    try:
        cli()
    except LoopChoiceError as exc:
        click.echo(f"Error: {exc}", err=True)
        raise SystemExit(2) from None
