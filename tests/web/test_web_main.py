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


def test_a_bad_or_remote_listen_is_refused_before_serving(store: Path) -> None:
    for listen, message in [
        ("8080", "--listen: expected HOST:PORT, got '8080'"),
        ("127.0.0.1:70000", "--listen: port must be a number 0..65535"),
        ("0.0.0.0:8080", "python -m sondalog.web: --listen: refusing to listen on 0.0.0.0"),
    ]:
        done = subprocess.run(
            [*WEB, "--store", str(store), "--listen", listen],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert done.returncode == 2, done.stderr
        assert message in done.stderr and "Traceback" not in done.stderr
