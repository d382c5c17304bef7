"""The end-of-run report of missing real peers (issue 16, item 6), run on a real pytest."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from peer_report import missing_peers

SKIPPING = """
import pytest

def test_pty(): pytest.skip("socat is not installed")

@pytest.mark.skipif(True, reason="lrzsz not installed")
def test_xmodem(): pass

def test_pop3(): pytest.skip("dovecot not found")

def test_other(): pytest.skip("needs a leap year")

def test_runs(): pass
"""


def _pytest(folder: Path) -> subprocess.CompletedProcess[str]:
    plugin_dir = Path(__file__).parent
    options = ["-p", "peer_report", "-p", "no:cacheprovider", "-c", "/dev/null"]
    return subprocess.run(
        [sys.executable, "-m", "pytest", *options, "--rootdir", str(folder), str(folder)],
        capture_output=True,
        text=True,
        timeout=60,
        env={"PYTHONPATH": str(plugin_dir), "PATH": "/usr/bin:/bin"},
    )


def test_missing_peers_and_the_install_line_are_printed(tmp_path: Path) -> None:
    (tmp_path / "test_skipping.py").write_text(SKIPPING)
    done = _pytest(tmp_path)
    assert done.returncode == 0, done.stdout
    out = done.stdout
    assert "real peers missing: tests skipped" in out
    assert "1 skipped without socat: socat is not installed" in out
    assert "1 skipped without lrzsz: lrzsz not installed" in out
    assert "1 skipped without dovecot: dovecot not found" in out
    assert "leap year" not in out
    assert out.index("sudo apt-get install -y dovecot-core dovecot-pop3d lrzsz socat") > out.index(
        "Install them"
    )


def test_nothing_is_printed_when_no_peer_is_missing(tmp_path: Path) -> None:
    (tmp_path / "test_fine.py").write_text("def test_fine(): pass\n")
    done = _pytest(tmp_path)
    assert done.returncode == 0 and "real peers missing" not in done.stdout


def test_reason_patterns() -> None:
    reasons = [
        "PostgreSQL (initdb) not found",
        "mosquitto broker missing",
        "chromium is not installed",
        "no gammu-smsd",
        "unrelated",
    ]
    assert list(missing_peers(reasons)) == ["postgresql", "mosquitto", "chromium", "gammu"]
