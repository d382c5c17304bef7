"""docs/protocol.md is generated from the parameter table and must match it."""

from __future__ import annotations

from pathlib import Path

from sondalog.ala1.params import LEAVES
from sondalog.app.docgen import render

DOC = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"


def test_protocol_reference_is_in_sync_with_the_table() -> None:
    assert DOC.read_text() == render(), "run `make docs` and commit docs/protocol.md"


def test_every_leaf_is_documented() -> None:
    text = DOC.read_text()
    for leaf in LEAVES:
        assert f"`{leaf.pattern}`" in text
        assert leaf.section.startswith("§")
