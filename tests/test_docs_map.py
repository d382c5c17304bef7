"""docs/architecture.md is the map of the code: every module is named on it."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "sondalog"


def test_every_module_is_on_the_map() -> None:
    text = (ROOT / "docs" / "architecture.md").read_text()
    a = text.index("## The package map")
    the_map = text[a : text.index("## The import rule")]
    named = set(re.findall(r"([A-Za-z_0-9]+)\.py", the_map))
    missing = sorted(
        str(p.relative_to(SRC))
        for p in SRC.rglob("*.py")
        if p.name != "__init__.py" and p.stem not in named
    )
    assert missing == [], (
        f"modules the package map of docs/architecture.md does not name: {missing}"
    )
