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
    # the pytest plugin (issue 23): starts sites through app, like the CLI; nothing imports it
    "testing": {"protocol", "io", "config", "client", "app"},
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
            # the schema, and the alarm store for the one write: an acknowledgement (issue 21)
            assert name in ("sondalog.collect.schema", "sondalog.collect.alarms.store"), (
                f"{path}:{line}: web reads only the schema (and asks for acks via AlarmStore)"
            )
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


#: Lines a module aims to stay under (issue 10: ~400 lines).
SIZE_AIM = 460
#: A module allowed past the aim never grows past this.
SIZE_CEILING = 900
#: Modules allowed past the aim -> why: one cohesive thing that splitting would hurt (a class
#: split across files only for the size made friend circles, issue 25 item 5). Empty today:
#: every circle of that kind was split along a narrow protocol instead.
OVER_THE_AIM: dict[str, str] = {}


def test_no_module_is_over_the_size_aim() -> None:
    """Modules stay small and named after what they hold; the allow-listed ones stay under
    the ceiling, and an entry goes when its module is back under the aim."""
    sizes = {str(p.relative_to(SRC)): len(p.read_text().splitlines()) for p in MODULES}
    big = {m: n for m, n in sizes.items() if n > SIZE_AIM and m not in OVER_THE_AIM}
    assert not big, big
    over = {m: sizes.get(m) for m in OVER_THE_AIM if not SIZE_AIM < sizes.get(m, 0) <= SIZE_CEILING}
    assert not over, f"allow-listed but missing, under the aim or over {SIZE_CEILING}: {over}"


def _module_name(path: Path) -> str:
    """``sondalog.a.b`` for ``src/sondalog/a/b.py`` (``sondalog.a`` for its ``__init__``)."""
    parts = path.relative_to(SRC.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_package(path: Path) -> bool:
    return path.name == "__init__.py"


MODULE_PATHS: dict[str, Path] = {_module_name(p): p for p in MODULES}


def _import_targets(path: Path, text: str | None = None) -> set[str]:
    """The ``sondalog`` modules ``path`` imports, from every import node (``ast.walk``: inside
    functions and under TYPE_CHECKING too). Relative imports are resolved; ``from pkg import
    mod`` names the module ``pkg.mod`` when that is a submodule, else ``pkg`` itself."""
    tree = ast.parse(path.read_text() if text is None else text, str(path))
    own = _module_name(path).split(".")
    package = own if _is_package(path) else own[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join((*base, *([node.module] if node.module else [])))
            else:
                module = node.module or ""
            for alias in node.names:
                sub = f"{module}.{alias.name}"
                found.add(sub if sub in MODULE_PATHS else module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {name for name in found if name in MODULE_PATHS and name != _module_name(path)}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def _import_graph() -> dict[str, set[str]]:
    return {name: _import_targets(path) for name, path in MODULE_PATHS.items()}


def test_no_module_circles_even_through_deferred_imports() -> None:
    """No module reaches itself through imports: not at module level, not inside a
    function, not under TYPE_CHECKING (issue 25 item 5). A class split across files that
    import each other back is one module in disguise: split along a narrow protocol, or
    keep it one module (the size allow-list)."""
    circles = [
        ", ".join(str(MODULE_PATHS[m].relative_to(SRC)) for m in component)
        for component in _cycles(_import_graph())
    ]
    assert not circles, "module circles:\n" + "\n".join(circles)


def test_the_circle_rule_sees_deferred_imports() -> None:
    """The rule's own check: imports inside functions, under TYPE_CHECKING, relative ones
    and ``from pkg import mod`` of a submodule all make edges, and a circle closed only
    through them is found."""
    engine = SRC / "ala1" / "engine.py"
    text = (
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from .modem.link import ModemLink\n"
        "def f():\n"
        "    from . import transfers\n"
        "    import sondalog.protocol.xmodem\n"
        "    from sondalog.ala1.modem import driver\n"
    )
    assert _import_targets(engine, text) == {
        "sondalog.ala1.modem.link",
        "sondalog.ala1.transfers",
        "sondalog.protocol.xmodem",
        "sondalog.ala1.modem.driver",
    }
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert _cycles(graph) == [["a", "b", "c"]]
