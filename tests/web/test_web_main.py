"""``python -m sondalog.web`` (issue 26): a taken address is named, and ``--help`` is plain
text (no reST markup printed literally)."""

from __future__ import annotations

import re
import socket
import subprocess
import sys
from pathlib import Path

WEB = [sys.executable, "-m", "sondalog.web"]


def test_a_taken_address_is_named(store: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [*WEB, "--store", str(store), "--listen", f"127.0.0.1:{port}"],
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert done.returncode == 2
    assert f"cannot listen on 127.0.0.1:{port}: Address already in use" in done.stderr
    assert "Traceback" not in done.stderr and done.stdout == ""


def test_help_is_plain_text() -> None:
    done = subprocess.run([*WEB, "--help"], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0
    assert "The dashboard alone, over an existing store" in done.stdout
    assert re.search(r"`|:(?:class|mod|func):", done.stdout) is None, done.stdout
