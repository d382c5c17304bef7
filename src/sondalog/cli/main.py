"""Entry point of the ``sondalog`` console script.

Each command group lives in its own module (``logger_cmd``, ``term_cmd``, ``bus_cmd``) and is
registered here, so the groups can grow independently.
"""

from __future__ import annotations

import importlib
import logging

import click

from sondalog import __version__

#: (module, attribute) of every command or group added to the root group.
COMMANDS: tuple[tuple[str, str], ...] = (
    ("sondalog.cli.logger_cmd", "logger"),
    ("sondalog.cli.term_cmd", "term"),
    ("sondalog.cli.bus_cmd", "bus"),
    ("sondalog.cli.serve_cmd", "serve"),
    ("sondalog.cli.collect_cmd", "collect"),
    ("sondalog.cli.phone_cmd", "phone"),
)
#: (module, attribute, parent group) of commands that belong to a group.
SUBCOMMANDS: tuple[tuple[str, str, str], ...] = (
    ("sondalog.cli.tables_cmd", "tables", "logger"),
    ("sondalog.cli.download_cmd", "download", "logger"),
)


@click.group()
@click.version_option(__version__, prog_name="sondalog")
@click.option("-v", "--verbose", count=True, help="More log output (repeat for debug).")
def cli(verbose: int) -> None:
    """sondalog: virtual ALA1 data loggers, HCTMPS1 sensor servers and host tools."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s %(message)s")


def _register() -> None:
    for module_name, attr in COMMANDS:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:
                continue  # command group not built yet
            raise
        cli.add_command(getattr(module, attr))
    for module_name, attr, parent in SUBCOMMANDS:
        group = cli.commands.get(parent)
        if isinstance(group, click.Group):
            group.add_command(getattr(importlib.import_module(module_name), attr))


_register()


def main() -> None:
    cli()
