"""The package map's import rule (docs/architecture.md), checked on every module of src/.

``protocol`` <- ``ala1``, ``hctmps1``, ``gsm`` <- ``world`` <- ``backends``; ``io`` uses only
``protocol``; ``app`` wires everything; ``cli`` parses and calls ``app`` (or the host side):
it reaches no core, world or backend, not even inside a function or under TYPE_CHECKING.
The host side (``client``, ``collect``, ``web``) uses only ``protocol``, ``io`` and ``client``
(and the collector's schema). No package imports the CLI, and no core imports I/O, storage,
simulation or wiring.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sondalog"

ALLOWED: dict[str, set[str]] = {
    "protocol": set(),
    "config": set(),
    "ala1": {"protocol", "config"},
    "hctmps1": {"protocol", "config"},
    "gsm": {"protocol", "config"},
    "world": {"protocol", "ala1", "hctmps1", "gsm", "config"},
    "backends": {"protocol", "ala1", "hctmps1", "gsm", "world", "io", "config"},
    "io": {"protocol", "config"},
    "client": {"protocol", "io", "config"},
    "collect": {"protocol", "io", "client", "config"},
    "web": {"protocol", "io", "collect", "config"},
    "app": {
        "protocol",
        "ala1",
        "hctmps1",
        "gsm",
        "world",
        "backends",
        "io",
        "config",
        "client",
        "collect",
        "web",
    },
    "demo": {"protocol", "io", "app", "client", "backends", "config"},
    "cli": {"protocol", "io", "config", "client", "collect", "web", "app"},
    "__init__": set(),
    "__main__": {"cli"},
}


def _package(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".py")


#: What the CLI never imports: it calls functions of ``app`` (or the host side) instead.
CLI_FORBIDDEN = ("ala1", "hctmps1", "gsm", "world", "backends")


def _imports(path: Path, text: str | None = None) -> list[tuple[int, str]]:
    """Every import of a ``sondalog`` module in ``path`` (or ``text`` as if it were there):
    every import node of the tree (``ast.walk``: inside functions, classes,
    ``if TYPE_CHECKING:`` and ``try:`` too)."""
    tree = ast.parse(path.read_text() if text is None else text, str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the module's own package
                base = path.relative_to(SRC).parts[: -node.level]
                target = ".".join(("sondalog", *base, *(node.module or "").split(".")))
                found.append((node.lineno, target.rstrip(".")))
            elif node.module:
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
    return [(line, name) for line, name in found if name.startswith("sondalog.")]


MODULES = sorted(SRC.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_imports_follow_the_package_map(path: Path) -> None:
    package = _package(path)
    allowed = ALLOWED[package]
    for line, name in _imports(path):
        target = name.split(".")[1]
        if "*" in allowed or target == package:
            continue
        if package == "web" and target == "collect":
            assert name == "sondalog.collect.schema", f"{path}:{line}: web reads only the schema"
            continue
        assert target in allowed, (
            f"{path.relative_to(SRC)}:{line} imports {name}: {package} may import only "
            f"{sorted(allowed) or 'the standard library'}"
        )


def _module_names(path: Path, text: str | None = None) -> list[tuple[int, str]]:
    """String constants that are a ``sondalog`` module's name (``importlib.import_module``)."""
    tree = ast.parse(path.read_text() if text is None else text, str(path))
    return [
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and re.fullmatch(r"sondalog(\.\w+)+", node.value)
    ]


def _cli_violations(path: Path, text: str | None = None) -> list[str]:
    return [
        f"{path.relative_to(SRC)}:{line} imports {name}: the CLI calls app (or client)"
        " functions instead"
        for line, name in [*_imports(path, text), *_module_names(path, text)]
        if name.split(".")[1] in CLI_FORBIDDEN
    ]


@pytest.mark.parametrize(
    "path",
    [p for p in MODULES if _package(p) == "cli"],
    ids=lambda p: str(p.relative_to(SRC)),
)
def test_the_cli_reaches_no_core_world_or_backend(path: Path) -> None:
    assert not _cli_violations(path)


def test_the_cli_rule_sees_imports_anywhere_in_a_module() -> None:
    """The rule's own check: imports inside functions, under TYPE_CHECKING, relative ones
    and module names handed to importlib are all seen; app and client ones pass."""
    text = (
        "from typing import TYPE_CHECKING\n"
        "import importlib\n"
        "if TYPE_CHECKING:\n"
        "    from sondalog.ala1.hardware import Hardware\n"
        "def f():\n"
        "    import sondalog.backends.linux.rs485\n"
        "    from ..hctmps1 import COMMAND_NAMES\n"
        "    from sondalog.app.logger import start_logger\n"
        "    from sondalog.client.bus import BusMaster\n"
        "    return importlib.import_module('sondalog.world.bus')\n"
    )
    found = _cli_violations(SRC / "cli" / "example_cmd.py", text)
    assert sorted(v.split(" imports ")[1].split(":")[0] for v in found) == [
        "sondalog.ala1.hardware",
        "sondalog.backends.linux.rs485",
        "sondalog.hctmps1",
        "sondalog.world.bus",
    ]
    assert found[0].startswith("cli/example_cmd.py:")


def test_no_module_is_over_the_size_aim() -> None:
    """Modules stay small and named after what they hold (issue 10: ~400 lines)."""
    big = {
        str(p.relative_to(SRC)): n for p in MODULES if (n := len(p.read_text().splitlines())) > 460
    }
    assert not big, big
