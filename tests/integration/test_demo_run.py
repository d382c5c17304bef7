"""``python -m sondalog.demo`` (what ``make demo`` runs) starts, shows its session, stops."""

from __future__ import annotations

import select
import signal
import subprocess
import sys
import time
from pathlib import Path


def test_demo_serves_and_stops_on_ctrl_c(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog.demo"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    lines: list[str] = []
    deadline = time.monotonic() + 20
    try:
        while not lines or lines[-1] != "Serving until Ctrl-C.\n":
            assert time.monotonic() < deadline, "".join(lines)
            ready, _, _ = select.select([proc.stdout], [], [], 1)
            if ready:
                line = proc.stdout.readline()
                assert line, "".join(lines) + proc.stderr.read() if proc.stderr else ""
                lines.append(line)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    text = "".join(lines)
    assert "sondalog term tcp://127.0.0.1:" in text
    assert "  <= 2.10\n" in text and "  <= ERROR\n" in text
    assert (tmp_path / "state" / "demo" / "identity.json").exists()
