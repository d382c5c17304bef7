"""Every ``sondalog ... --help`` renders as plain text (issue 16, item 7): no reST or Markdown
markup that click would print literally."""

from __future__ import annotations

import re

import click
from click.testing import CliRunner

from sondalog.cli.main import cli

MARKUP = re.compile(r"`|\*\*|:(?:class|func|mod|meth|data):|^\s*\.\. ", re.MULTILINE)


def _commands(group: click.Group, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    found = [path]
    ctx = click.Context(group)
    for name in group.list_commands(ctx):  # lazy groups import their commands here
        command = group.get_command(ctx, name)
        assert command is not None, name
        if isinstance(command, click.Group):
            found += _commands(command, (*path, name))
        else:
            found.append((*path, name))
    return found


def test_every_help_text_is_plain() -> None:
    paths = _commands(cli)
    assert ("logger", "tables", "push") in paths and ("bus", "scan") in paths
    runner = CliRunner()
    for path in paths:
        result = runner.invoke(cli, [*path, "--help"], terminal_width=100)
        assert result.exit_code == 0, (path, result.output)
        assert result.output.startswith("Usage: "), path
        assert MARKUP.search(result.output) is None, (path, result.output)
