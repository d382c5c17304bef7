"""Issue 23: the documented example of a user's test suite (examples/ci/) passes with the
plugin, run by pytest in a subprocess as a user runs it, and imports nothing but
``sondalog.testing`` and the client."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "ci"


def test_the_example_suite_passes(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "sondalog.testing", "-p", "no:cacheprovider",
         "-q", "-rA", str(EXAMPLE)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    tests = [n for n in ast.walk(_tree()) if isinstance(n, ast.FunctionDef)]
    passed = [line for line in done.stdout.splitlines() if line.startswith("PASSED")]
    assert len(passed) == len([t for t in tests if t.name.startswith("test_")]) == 8


def _tree() -> ast.Module:
    return ast.parse((EXAMPLE / "test_with_sondalog.py").read_text())


def test_the_example_imports_only_the_plugin_and_the_client() -> None:
    modules = set()
    for node in ast.walk(_tree()):
        if isinstance(node, ast.ImportFrom):
            modules.add(node.module or "")
        elif isinstance(node, ast.Import):
            modules |= {alias.name for alias in node.names}
    sondalog = {m for m in modules if m.startswith("sondalog")}
    assert sondalog and all(
        m == "sondalog.testing" or m == "sondalog.client" or m.startswith("sondalog.client.")
        for m in sondalog
    ), sondalog
    assert modules - sondalog <= {"__future__", "pytest"}


def test_the_plugin_is_registered_by_its_entry_point() -> None:
    """pyproject.toml: the ``pytest11`` entry point, named after the module, so that
    ``-p sondalog.testing`` where it is installed too loads it once."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["entry-points"]["pytest11"] == {"sondalog.testing": "sondalog.testing"}
    assert (EXAMPLE / "README.md").read_text().count("pytest") >= 3
