"""The package map's import rule (docs/architecture.md), checked on every module of src/.

``protocol`` <- ``ala1``, ``hctmps1``, ``gsm`` <- ``world`` <- ``backends``; ``io`` uses only
``protocol``; ``app`` wires everything; ``cli`` parses. The host side (``client``,
``collect``, ``web``) uses only ``protocol``, ``io`` and ``client`` (and the collector's schema).
No package imports the CLI, and no core imports I/O, storage, simulation or wiring.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "sondalog"

ALLOWED: dict[str, set[str]] = {
    "protocol": set(),
    "sitefile": set(),
    "ala1": {"protocol"},
    "hctmps1": {"protocol"},
    "gsm": {"protocol"},
    "world": {"protocol", "ala1", "hctmps1", "gsm"},
    "backends": {"protocol", "ala1", "hctmps1", "gsm", "world", "io", "sitefile"},
    "io": {"protocol"},
    "client": {"protocol", "io"},
    "collect": {"protocol", "io", "client", "sitefile"},
    "web": {"protocol", "io", "collect"},
    "app": {
        "protocol",
        "ala1",
        "hctmps1",
        "gsm",
        "world",
        "backends",
        "io",
        "sitefile",
        "client",
        "collect",
        "web",
    },
    "demo": {"protocol", "io", "app", "client", "backends"},
    "cli": {"*"},
    "__init__": set(),
    "__main__": {"cli"},
}


def _package(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".py")


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), str(path))
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


def test_no_module_is_over_the_size_aim() -> None:
    """Modules stay small and named after what they hold (issue 10: ~400 lines)."""
    big = {
        str(p.relative_to(SRC)): n for p in MODULES if (n := len(p.read_text().splitlines())) > 460
    }
    assert not big, big
