"""Issue 25 item 1: every configuration format goes through the one typed reader.

Checked on every module of ``src/`` outside ``sondalog/config/``:

- no hand-written type check of a value: ``isinstance(x, bool)`` is how a reader tells
  ``true`` from ``1``, so it appears only in the reader;
- no TOML parsing (``tomllib``) and no line lookups (``locate``) of its own;
- no error type of its own for configuration (``...ConfigError``), no local ``fail()``
  closures making errors with file and line, no HOST:PORT parsing or loopback test by hand.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "sondalog"
MODULES = sorted(p for p in SRC.rglob("*.py") if "config" not in p.relative_to(SRC).parts[:1])


def _name(node: ast.expr) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return ""


def _offences(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(), str(path))
    found = []
    for node in ast.walk(tree):
        where = f"{path.relative_to(SRC)}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.Call) and _name(node.func) == "isinstance" and len(node.args) == 2:
            kinds = node.args[1]
            names = [_name(e) for e in kinds.elts] if isinstance(kinds, ast.Tuple) else []
            if isinstance(kinds, ast.BinOp):  # int | float
                names = [_name(kinds.left), _name(kinds.right)]
            if "bool" in names or _name(kinds) == "bool":
                found.append(f"{where}: isinstance(..., bool) outside the reader")
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names = [a.name for a in node.names]
            module = getattr(node, "module", None) or ""
            if "tomllib" in names or module == "tomllib":
                found.append(f"{where}: parses TOML itself (use sondalog.config.load)")
            if module.startswith("sondalog.config") and {"locate", "Fail"} & set(names):
                found.append(f"{where}: looks up lines itself (use Table.fail)")
        elif isinstance(node, ast.ClassDef) and node.name.endswith("ConfigError"):
            found.append(f"{where}: a second configuration error type {node.name}")
        elif isinstance(node, ast.FunctionDef) and node.name in {"is_loopback", "parse_listen"}:
            found.append(f"{where}: a second {node.name} (use sondalog.config)")
    return found


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(SRC)))
def test_configuration_is_read_only_by_the_reader(path: Path) -> None:
    assert _offences(path) == []


def test_the_rule_catches_what_it_forbids(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import tomllib\n"
        "from sondalog.config import locate\n"
        "class GsmConfigError(ValueError): ...\n"
        "def is_loopback(h): ...\n"
        "def f(v):\n    return isinstance(v, bool) or isinstance(v, (int, bool))\n"
    )
    global SRC
    old, SRC = SRC, tmp_path
    try:
        assert len(_offences(bad)) == 6
    finally:
        SRC = old
