"""docs/gsm.md names every command the modem answers (the reference does not drift)."""

from __future__ import annotations

from pathlib import Path

from sondalog.gsm.modem import Modem

DOC = Path(__file__).resolve().parents[2] / "docs" / "gsm.md"


def test_every_command_is_documented() -> None:
    text = DOC.read_text(encoding="utf-8")
    missing = [name for name in Modem().handlers if f"AT{name}" not in text]
    assert missing == []
    assert "\n## Walkthrough" in text
