"""``examples/collector.toml`` as a new user runs it (issue 26): peers served from the example
site files, the fresh logger set up with the commands the example's header gives, then
``sondalog collect --once``: rows at the first run, the logger's clock on time, and the
one-line-per-contact log only with ``-v`` (docs/collector.md)."""

from __future__ import annotations

import contextlib
import re
import select
import signal
import sqlite3
import subprocess
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

from served_logger import CLI, serving

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@contextlib.contextmanager
def _bus(tmp: Path) -> Iterator[str]:
    site = str(EXAMPLES / "bus-site.toml")
    command = [*CLI, "bus", "serve", "--site", site, "--listen", "127.0.0.1:0"]
    proc = subprocess.Popen(
        [*command, "--state", str(tmp / "bus")], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL
    )
    try:
        assert proc.stdout is not None
        assert select.select([proc.stdout], [], [], 15)[0]
        line = proc.stdout.readline().decode()
        assert line.startswith("listening on "), line
        yield "tcp://" + line.removeprefix("listening on ").strip()
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _setup_commands(example: str) -> list[str]:
    """The logger commands of the example's header (``sondalog term URL <<EOF`` ... ``EOF``),
    with the shell's ``$(date -u +%Y%m%d%H%M%S)`` done here."""
    lines = [line.removeprefix("#").strip() for line in example.splitlines()]
    start = next(i for i, line in enumerate(lines) if line.endswith("<<EOF"))
    end = lines.index("EOF", start)
    now = datetime.now(UTC).strftime("%Y%m%d%H%M%S")
    return [line.replace("$(date -u +%Y%m%d%H%M%S)", now) for line in lines[start + 1 : end]]


def _collect(config: Path, *verbose: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, *verbose, "collect", "--once", str(config)],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_the_example_yields_data_at_its_first_run(tmp_path: Path) -> None:
    example = (EXAMPLES / "collector.toml").read_text(encoding="utf-8")
    site = str(EXAMPLES / "logger-site.toml")
    with serving(tmp_path, "--site", site) as logger, _bus(tmp_path) as bus:
        config = tmp_path / "collector.toml"
        config.write_text(
            example.replace("tcp://127.0.0.1:10001", logger.url)
            .replace("tcp://127.0.0.1:10485", bus)
            .replace("../state/collector.sqlite", "store.sqlite"),
            encoding="utf-8",
        )
        fresh = _collect(config)  # before the set-up: nothing, and the collector says why
        assert fresh.returncode == 0, fresh.stderr
        assert "demo-logger: its clock reads 2000-01-01" in fresh.stderr, fresh.stderr
        assert "nothing to collect: its record is empty" in fresh.stderr

        logger.ask(*_setup_commands(example))
        first = _collect(config)
        assert first.returncode == 0, first.stderr
        assert "source demo-logger:" not in first.stderr  # the contact lines need -v
        assert "nothing to collect" not in first.stderr
        verbose = _collect(config, "-v")
        assert verbose.returncode == 0, verbose.stderr
        assert re.search(r"source demo-logger: logger \S+: \d+ new rows", verbose.stderr)
    with contextlib.closing(sqlite3.connect(tmp_path / "store.sqlite")) as db:
        rows = db.execute(
            "SELECT count(*), min(utc) FROM readings WHERE logger NOT LIKE 'bus:%'"
        ).fetchone()
        (offset,) = db.execute("SELECT offset_s FROM sources WHERE name = 'demo-logger'").fetchone()
        bus_rows = db.execute("SELECT count(*) FROM readings WHERE logger LIKE 'bus:%'").fetchone()
    assert rows[0] >= 1 and rows[1].endswith("Z")
    assert abs(offset) < 120  # a logger set to UTC is on time, not an hour "behind"
    assert bus_rows[0] >= 3
