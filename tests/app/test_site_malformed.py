"""Malformed site files (issue 25 item 1): ``serve --check`` refuses each with exit 2 and
the file, line and field, before anything starts, instead of a traceback, a runaway read
or a failure after start."""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "site.toml"


def _check(site: Path, *args: str) -> subprocess.CompletedProcess[str]:
    def limit_memory() -> None:  # the old reader read /dev/zero without end
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    return subprocess.run(
        [sys.executable, "-m", "sondalog", "serve", "--check", str(site), *args],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=limit_memory,
    )


def _example(tmp_path: Path, *edits: tuple[str, str]) -> Path:
    text = EXAMPLE.read_text()
    for old, new in edits:
        assert old in text
        text = text.replace(old, new, 1)
    site = tmp_path / "site.toml"
    site.write_text(text)
    return site


def test_the_example_site_passes_the_check(tmp_path: Path) -> None:
    done = _check(_example(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "no clash" in done.stdout


def test_a_file_that_is_not_utf8_is_refused_at_its_line(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_bytes(b'[logger]\nbackend = "sim"  # \xe9t\xe9\n')
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:2: file: not UTF-8 text" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_symlink_to_dev_zero_is_refused_at_once(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.symlink_to("/dev/zero")
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}: file: not a regular file" in done.stderr


def test_a_file_over_the_size_limit_is_refused(tmp_path: Path) -> None:
    site = _example(tmp_path)
    site.write_text(site.read_text() + "# padding\n" * 120_000)
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}: file: larger than 1048576 bytes" in done.stderr


def test_a_non_finite_number_is_refused_at_its_field(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(
        '[bus]\nbaud = 9600\n\n[bus.serve]\nserial = "/dev/ttyUSB9"\nrs485 = "rts"\n'
        "delay_before_tx = 1e309\n"
    )
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:7: bus.serve.delay_before_tx: inf is not a finite number" in done.stderr


def test_the_logger_and_the_bus_on_one_port_are_refused_before_start(tmp_path: Path) -> None:
    site = _example(tmp_path, ('listen = "127.0.0.1:10485"', 'listen = "127.0.0.1:10001"'))
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:35: bus.serve.listen: port 10001 is already used by logger.serve.listen" in (
        done.stderr
    )


def test_smtp_and_pop3_on_one_port_are_refused_before_start(tmp_path: Path) -> None:
    site = _example(tmp_path, ('pop3 = "127.0.0.1:1110"', 'pop3 = "127.0.0.1:2525"'))
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:39: mail.pop3: port 2525 is already used by mail.smtp" in done.stderr


def test_a_wildcard_host_clashes_with_loopback_on_the_same_port(tmp_path: Path) -> None:
    site = _example(tmp_path, ('listen = "127.0.0.1:10485"', 'listen = "0.0.0.0:10001"'))
    done = _check(site, "--allow-remote")
    assert done.returncode == 2, done.stderr
    assert f"{site}:35: bus.serve.listen: port 10001 is already used by" in done.stderr


def test_a_missing_fleet_site_file_is_reported_at_the_line_naming_it(tmp_path: Path) -> None:
    site = tmp_path / "fleet.toml"
    site.write_text(
        '[[loggers]]\nserial_number = "A1"\nlisten = "127.0.0.1:0"\nsite = "station.toml"\n'
    )
    done = _check(site)
    assert done.returncode == 2, done.stderr
    missing = tmp_path / "station.toml"
    assert f"{site}:4: loggers[0].site: {missing}: cannot read" in done.stderr


def test_a_fleet_site_file_that_is_dev_zero_is_refused_at_its_line(tmp_path: Path) -> None:
    (tmp_path / "station.toml").symlink_to("/dev/zero")
    site = tmp_path / "fleet.toml"
    site.write_text(
        '[[loggers]]\nserial_number = "A1"\nlisten = "127.0.0.1:0"\nsite = "station.toml"\n'
    )
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:4: loggers[0].site: " in done.stderr
    assert "not a regular file" in done.stderr


def test_a_misspelt_table_is_refused_with_a_suggestion(tmp_path: Path) -> None:
    site = _example(tmp_path, ("[bus]", "[bsu]"), ("[bus.serve]", "[bsu.serve]"))
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:20: bsu: unknown table" in done.stderr
    assert "did you mean bus?" in done.stderr


def test_a_missing_board_file_is_reported_at_the_line_naming_it(tmp_path: Path) -> None:
    site = _example(tmp_path)
    site.write_text('board = "board.toml"\n' + site.read_text())
    done = _check(site)
    assert done.returncode == 2, done.stderr
    assert f"{site}:1: board: {tmp_path / 'board.toml'}: cannot read" in done.stderr
