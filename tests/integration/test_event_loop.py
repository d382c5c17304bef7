"""The serving commands run on uvloop when it is installed (``sondalog[fast]``, issue 11), on
the standard loop with ``SONDALOG_LOOP=asyncio``; both answer the same bytes."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest
from ala1_served import ServedLogger, exchange


def _loop_of(pid: int) -> str:
    maps = Path(f"/proc/{pid}/maps").read_text()
    return "uvloop" if "/uvloop/" in maps else "asyncio"


@pytest.mark.parametrize("choice", ["asyncio", "uvloop"])
def test_served_logger_on_each_loop(tmp_path: Path, choice: str) -> None:
    if choice == "uvloop" and importlib.util.find_spec("uvloop") is None:
        pytest.skip("uvloop is not installed (sondalog[fast])")
    old = os.environ.get("SONDALOG_LOOP")
    os.environ["SONDALOG_LOOP"] = choice
    try:
        served = ServedLogger(tmp_path / "state")
    finally:
        if old is None:
            del os.environ["SONDALOG_LOOP"]
        else:
            os.environ["SONDALOG_LOOP"] = old
    try:
        assert _loop_of(served.proc.pid) == choice
        with served.connect() as sock:
            assert exchange(sock, b"read i version\r", b"OK\r\n") == b"2.10\r\nOK\r\n"
            assert exchange(sock, b"read xyz\r", b"ERROR\r\n").endswith(b"ERROR\r\n")
    finally:
        served.kill()


def test_a_bad_loop_choice_is_refused(tmp_path: Path) -> None:
    env = {**os.environ, "SONDALOG_LOOP": "fastest"}
    result = subprocess.run(
        [sys.executable, "-m", "sondalog", "logger", "serve", "--listen", "127.0.0.1:0",
         "--state", str(tmp_path / "state")],
        env=env, capture_output=True, text=True, timeout=30,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith("Error: SONDALOG_LOOP='fastest'"), result.stderr
