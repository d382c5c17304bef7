"""Malformed collector files (issue 25 item 1): ``collect --check`` refuses each with exit 2
and the file, line and field, instead of a traceback, a runaway read or a crash at start."""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

GOOD = """\
[sqlite]
path = "store.sqlite"

[[source]]
url = "tcp://127.0.0.1:10001"
interval = 30
"""


def _check(config: Path) -> subprocess.CompletedProcess[str]:
    def limit_memory() -> None:  # the old reader read /dev/zero without end
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    return subprocess.run(
        [sys.executable, "-m", "sondalog", "collect", "--check", str(config)],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=limit_memory,
        cwd=config.parent,
    )


def _config(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "collector.toml"
    path.write_text(text)
    return path


def test_a_good_file_passes(tmp_path: Path) -> None:
    done = _check(_config(tmp_path, GOOD))
    assert done.returncode == 0, done.stderr


def test_an_infinite_interval_is_refused_at_its_line(tmp_path: Path) -> None:
    config = _config(tmp_path, GOOD.replace("interval = 30", "interval = 1e309"))
    done = _check(config)
    assert done.returncode == 2, done.stderr
    assert f"{config}:6: source[0].interval: inf is not a finite number" in done.stderr


def test_nan_as_a_timeout_is_refused_at_its_line(tmp_path: Path) -> None:
    config = _config(tmp_path, GOOD + "timeout = nan\n")
    done = _check(config)
    assert done.returncode == 2, done.stderr
    assert f"{config}:7: source[0].timeout: nan is not a finite number" in done.stderr


def test_a_store_path_that_is_a_directory_is_refused_by_check(tmp_path: Path) -> None:
    config = _config(tmp_path, GOOD.replace('path = "store.sqlite"', 'path = "."'))
    done = _check(config)
    assert done.returncode == 2, done.stderr
    assert f"{config}:2: sqlite.path: " in done.stderr
    assert "is a directory" in done.stderr


def test_a_file_that_is_not_utf8_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "collector.toml"
    config.write_bytes(GOOD.encode() + b'name = "m\xeb\xe9t\xe9o"\n')
    done = _check(config)
    assert done.returncode == 2, done.stderr
    assert f"{config}:7: file: not UTF-8 text" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_symlink_to_dev_zero_is_refused_at_once(tmp_path: Path) -> None:
    config = tmp_path / "collector.toml"
    config.symlink_to("/dev/zero")
    done = _check(config)
    assert done.returncode == 2, done.stderr
    assert f"{config}: file: not a regular file" in done.stderr
