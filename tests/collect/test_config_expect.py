"""``expect = "station.toml"`` on a collector's source (issue 22): the station file read with
the collector's file (errors with file, line and field; exit 2), and a real collector raising
a ``health`` ``drift`` alarm (notified through ``[[notify]]``) when a served logger drifts from
it, cleared when the file is applied again."""

from __future__ import annotations

import contextlib
import sqlite3
from pathlib import Path

import pytest
from collector_run import cli, collecting, events, states, wait_for
from served_logger import serving

from sondalog.collect.config import parse_config
from sondalog.config import ConfigError, load

STATION = """protocol = "2.10"

[identity]
name = "weir"

[channel.1]
sampling_period = "000100"
"""
RULES = """
[[notify]]
name = "log"
kind = "log"

[[alarm]]
kind = "health"
name = "drift"
measure = "drift"
notify = ["log"]
"""


def _collector(tmp: Path, source: str, extra: str = "") -> Path:
    path = tmp / "collector.toml"
    path.write_text(f"[web]\nenabled = false\n\n[[source]]\n{source}\n{extra}")
    return path


def _error(tmp: Path, source: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_config(load(_collector(tmp, source)))
    return str(info.value)


def test_the_expected_station_file_is_read_with_the_collectors_file(tmp_path: Path) -> None:
    (tmp_path / "station.toml").write_text(STATION)
    config = parse_config(
        load(_collector(tmp_path, 'url = "tcp://127.0.0.1:1"\nexpect = "station.toml"'))
    )
    (source,) = config.sources
    assert source.expect is not None and source.config_every == 1
    assert source.expect.values == {"i name": "weir", "channel 1 sampling period": "000100"}
    assert source.expect_path == str(tmp_path / "station.toml")


def test_a_bad_expect_is_refused_with_file_line_and_field(tmp_path: Path) -> None:
    url = 'url = "tcp://127.0.0.1:1"\n'
    assert _error(tmp_path, url + 'expect = "nowhere.toml"').startswith(
        f"{tmp_path / 'collector.toml'}:6: source[0].expect: {tmp_path / 'nowhere.toml'}: no such"
    )
    (tmp_path / "station.toml").write_text(STATION + "sampling_perod = 1\n")
    message = _error(tmp_path, url + 'expect = "station.toml"')
    assert message.startswith(f"{tmp_path / 'station.toml'}:8: channel.1.sampling_perod:"), message
    (tmp_path / "station.toml").write_text(STATION.replace('"000100"', '"0001000"'))
    message = _error(tmp_path, url + 'expect = "station.toml"')
    assert message.startswith(f"{tmp_path / 'station.toml'}:7: channel.1.sampling_period:"), message
    (tmp_path / "station.toml").write_text(STATION)
    message = _error(tmp_path, 'kind = "bus"\nurl = "tcp://127.0.0.1:1"\nexpect = "station.toml"')
    assert "source[0].expect: only a logger source has its configuration read" in message
    message = _error(tmp_path, url + 'expect = "station.toml"\nconfig_every = 0')
    assert "source[0].config_every: 0 never reads the configuration" in message
    (tmp_path / "fleet.toml").write_text('[[logger]]\nurl = "tcp://127.0.0.1:2"\n')
    message = _error(tmp_path, url + 'expect = "fleet.toml"')
    assert "fleet.toml has no [[logger]] with url = 'tcp://127.0.0.1:1'" in message


def test_a_bad_station_file_stops_the_collector_at_start(tmp_path: Path) -> None:
    (tmp_path / "station.toml").write_text("[channel.1]\ntype = 4\n")
    path = _collector(tmp_path, 'url = "tcp://127.0.0.1:1"\nexpect = "station.toml"')
    for args in (("collect", "--check", str(path)), ("collect", "--once", str(path))):
        done = cli(*args)
        assert done.returncode == 2, done
        assert f"{tmp_path / 'station.toml'}:2: channel.1.type:" in done.stderr
    assert not (tmp_path / "collector.sqlite").exists()


def _drift(store: Path) -> int | None:
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        row = db.execute("SELECT drift FROM config_state").fetchone()
        return None if row is None else row[0]
    return None


def _config_events(store: Path) -> list[str]:
    with contextlib.closing(sqlite3.connect(store, timeout=5)) as db:
        rows = db.execute("SELECT text FROM events WHERE kind = 'config' ORDER BY id")
        return [str(r[0]) for r in rows]


def test_a_drift_raises_and_a_reapply_clears(tmp_path: Path) -> None:
    (tmp_path / "station.toml").write_text(STATION)
    with serving(tmp_path) as logger:
        applied = cli(
            "logger", "config", "apply", logger.url, str(tmp_path / "station.toml"), "--yes"
        )
        assert applied.returncode == 0, applied
        config = _collector(
            tmp_path,
            f'url = "{logger.url}"\nname = "weir"\ninterval = 0.5\ntimeout = 3\n'
            'expect = "station.toml"\n',
            RULES,
        )
        store = tmp_path / "collector.sqlite"
        with collecting(config):
            wait_for(lambda: _drift(store) == 0, 30, config, "a first check, no drift")
            assert states(store).get(("drift", "000001"), "ok") == "ok"
            # the technician changes a setting the file gives, and one it leaves at factory
            logger.ask("write channel 1 sampling period 000500", "write global timing 64")
            wait_for(lambda: _drift(store) == 2, 30, config, "the drift")
            wait_for(lambda: states(store).get(("drift", "000001")) == "raised", 30, config,
                     "the drift alarm")  # fmt: skip
            drifts = [e for e in _config_events(store) if e.startswith("configuration drifts")]
            assert drifts == [
                f"configuration drifts from {tmp_path / 'station.toml'}: 2 settings\n"
                "channel 1 sampling period: 000500 -> 000100\n"
                "global timing: 64 -> 8"
            ]
            again = cli(
                "logger", "config", "apply", logger.url, str(tmp_path / "station.toml"), "--yes"
            )
            assert again.returncode == 0, again
            wait_for(lambda: _drift(store) == 0, 30, config, "the drift gone")
            wait_for(lambda: states(store).get(("drift", "000001")) == "cleared", 30, config,
                     "the drift alarm cleared")  # fmt: skip
        assert [w for w, _, _ in events(store, "drift")] == ["raised", "cleared"]
        texts = _config_events(store)
        assert texts[-1] == f"configuration matches {tmp_path / 'station.toml'} again"
        # the log notifier said it too (the [[notify]] of kind log)
        log = (tmp_path / "collect.log").read_text()
        assert "drift: 000001 drift 2 above 0" in log
