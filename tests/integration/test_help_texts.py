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


def _own_options(path: tuple[str, ...]) -> set[str]:
    command: click.Command = cli
    for name in path:
        assert isinstance(command, click.Group)
        found = command.get_command(click.Context(command), name)
        assert found is not None, path
        command = found
    return {o for p in command.params for o in (*p.opts, *p.secondary_opts)} | {"--help"}


def test_options_section_names_only_options_the_command_has() -> None:
    """Issue 26: ``serve --help`` offered --allow-remote for "a --listen address", an option
    ``serve`` does not have (its addresses are in the site file)."""
    runner = CliRunner()
    for path in _commands(cli):
        output = runner.invoke(cli, [*path, "--help"], terminal_width=100).output
        _, _, options = output.partition("\nOptions:\n")
        named = set(re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", options))
        assert named <= _own_options(path), (path, named - _own_options(path), output)
    serve = runner.invoke(cli, ["serve", "--help"], terminal_width=100).output
    assert "--allow-remote" in serve and "site file" in serve.partition("--allow-remote")[2]
