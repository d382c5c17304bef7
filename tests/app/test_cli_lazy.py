"""``sondalog --help`` lists every command without importing it (issue 11: start-up), with the
same short help the command modules give."""

from __future__ import annotations

import importlib
import subprocess
import sys

import click
from click.testing import CliRunner

from sondalog.cli.main import COMMANDS, SUBCOMMANDS, cli


def test_stored_help_agrees_with_each_command() -> None:
    for name, entry in {**COMMANDS, **SUBCOMMANDS}.items():
        command = getattr(importlib.import_module(entry.module), entry.attr)
        assert isinstance(command, click.Command), name
        placeholder = click.Command(name, help=entry.help)
        for limit in (30, 45, 200):
            assert placeholder.get_short_help_str(limit) == command.get_short_help_str(limit), name


def test_help_imports_no_command_module() -> None:
    code = (
        "import sys\n"
        "from sondalog.cli.main import cli\n"
        "try:\n"
        "    cli(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "loaded = sorted(m for m in sys.modules if m.startswith('sondalog.') and m not in\n"
        "    ('sondalog.cli', 'sondalog.cli.main'))\n"
        "print('LOADED', loaded)\n"
        "print('HEAVY', sorted(m for m in ('asyncio', 'rich', 'sqlite3') if m in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert "LOADED []" in out, out
    assert "HEAVY []" in out, out
    for name in COMMANDS:
        assert f"  {name} " in out, (name, out)


def test_lazy_groups_list_and_run_their_subcommands() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["logger", "--help"], terminal_width=100)
    assert result.exit_code == 0, result.output
    for name in ("serve", "tables", "download"):
        assert f"  {name} " in result.output, result.output
    result = runner.invoke(cli, ["logger", "tables", "--help"])
    assert result.exit_code == 0 and "push" in result.output, result.output
    result = runner.invoke(cli, ["nosuch"])
    assert result.exit_code == 2 and "No such command" in result.output
