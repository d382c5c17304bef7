"""Backend tests: ``@pytest.mark.hardware`` tests need a real board and are skipped elsewhere.

Run them on a board with ``SONDALOG_HARDWARE=1`` (and the variables each test names).
"""

from __future__ import annotations

import os

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "hardware: needs a real Linux board (run with SONDALOG_HARDWARE=1)"
    )


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("SONDALOG_HARDWARE") == "1":
        return
    skip = pytest.mark.skip(reason="needs a real board: set SONDALOG_HARDWARE=1 on one")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)
