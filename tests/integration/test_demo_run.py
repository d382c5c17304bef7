"""``python -m sondalog.demo`` (what ``make demo`` runs) starts, shows its session, stops."""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path


def test_demo_serves_and_stops_on_ctrl_c(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog.demo"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert proc.stdout is not None
    lines: queue.Queue[str] = queue.Queue()
    reader = threading.Thread(target=lambda: [lines.put(x) for x in proc.stdout or ()])
    reader.start()
    seen: list[str] = []
    try:
        while not seen or seen[-1] != "Serving until Ctrl-C.\n":
            try:
                seen.append(lines.get(timeout=20))
            except queue.Empty:
                raise AssertionError("".join(seen)) from None
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        reader.join(timeout=10)
    text = "".join(seen)
    assert "sondalog term tcp://127.0.0.1:" in text
    assert "  <= 2.10\n" in text and "  <= ERROR\n" in text
    assert (tmp_path / "state" / "demo" / "identity.json").exists()
