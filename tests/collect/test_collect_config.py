"""The collector's configuration file: errors name the file, the line and the field."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from served_logger import CLI

from sondalog.collect.config import CollectorConfig, load_config
from sondalog.config import ConfigError

GOOD = """\
[sqlite]
path = "data/store.sqlite"

[[source]]
url = "tcp://127.0.0.1:10001"
interval = 30
timezone = "Europe/Prague"

[[source]]
kind = "bus"
url = "tcp://127.0.0.1:10485"
name = "greenhouse"
modules = ["T1"]
units = { T1 = "°C" }
"""


def _load(tmp_path: Path, text: str) -> CollectorConfig:
    path = tmp_path / "collector.toml"
    path.write_text(text)
    return load_config(path)


def test_a_good_file(tmp_path: Path) -> None:
    config = _load(tmp_path, GOOD)
    assert config.store == tmp_path / "data" / "store.sqlite"
    assert config.buffer == tmp_path / "data" / "store.buffer.sqlite"
    logger, bus = config.sources
    assert (logger.name, logger.interval, logger.kind, str(logger.zone)) == (
        "tcp://127.0.0.1:10001",
        30.0,
        "logger",
        "Europe/Prague",
    )
    assert (bus.name, bus.modules, bus.units, bus.interval) == (
        "greenhouse",
        ("T1",),
        {"T1": "°C"},
        60.0,
    )


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (("interval = 30", "interval = -1"), ":6: source[0].interval: must be a positive"),
        (("interval = 30", "interval = true"), ":6: source[0].interval: must be a positive"),
        (('timezone = "Europe/Prague"', 'timezone = "Mars/Olympus"'), ":7: source[0].timezone"),
        (('url = "tcp://127.0.0.1:10001"', 'url = "http://x"'), ":5: source[0].url: unsupported"),
        (
            ('name = "greenhouse"', 'nmae = "x"'),
            ":12: source[1].nmae: unknown table or key 'nmae' (did you mean name? ",
        ),
        (('kind = "bus"', 'kind = "fax"'), ":10: source[1].kind: must be one of"),
        (('path = "data/store.sqlite"', "path = 3"), ":2: sqlite.path: must be a path"),
        (('path = "data/store.sqlite"', 'path = "."'), ":2: sqlite.path: "),
        (
            ('path = "data/store.sqlite"', 'path = "x"\nreadings = 1'),
            ":3: sqlite.readings: must be true",
        ),
        (
            ("[sqlite]", "[sqlight]"),
            ":1: sqlight: unknown table or key 'sqlight' (did you mean sqlite? ",
        ),
        (("[sqlite]", "[sqlte]"), ":1: sqlte: unknown table or key 'sqlte' (did you mean sqlite? "),
        (('name = "greenhouse"', 'name = "tcp://127.0.0.1:10001"'), ":12: source[1].name: "),
        (("interval = 30", "interval = 30\nmodules = ['T1']"), ":7: source[0].modules: only a bus"),
    ],
)
def test_errors_name_file_line_and_field(
    tmp_path: Path, change: tuple[str, str], where: str
) -> None:
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, GOOD.replace(*change))
    assert str(info.value).startswith(str(tmp_path / "collector.toml") + where), str(info.value)


def test_syntax_error_and_missing_sources(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"collector.toml: toml: .*line 2"):
        _load(tmp_path, "[sqlite]\npath = \n")
    with pytest.raises(ConfigError, match="source: no \\[\\[source\\]\\] table"):
        _load(tmp_path, "[sqlite]\npath = 'x.sqlite'\n")


def test_cli_exit_2_with_the_message(tmp_path: Path) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(GOOD.replace("interval = 30", "interval = 'often'"))
    done = subprocess.run([*CLI, "collect", str(path)], capture_output=True, text=True, timeout=30)
    assert done.returncode == 2
    assert f"{path}:6: source[0].interval: must be a positive number of seconds" in done.stderr
    path.write_text(GOOD + "\n[postgres]\ndsn = 'postgresql://x'\nbogus = 1\n")
    done = subprocess.run([*CLI, "collect", str(path)], capture_output=True, text=True, timeout=30)
    assert done.returncode == 2
    assert f"{path}:18: postgres.bogus: unknown table or key 'bogus'" in done.stderr
    assert not (tmp_path / "data" / "store.buffer.sqlite").exists()


def test_the_example_file() -> None:
    example = Path(__file__).resolve().parents[2] / "examples" / "collector.toml"
    config = load_config(example)
    assert [s.name for s in config.sources] == ["demo-logger", "demo-bus"]
    assert config.store.name == "collector.sqlite" and not config.sinks


@pytest.mark.parametrize(
    ("sink", "message"),
    [
        ("[mqtt]\nurl = 'http://broker'\n", ":17: mqtt.url: 'http://broker' is not mqtt://"),
        ("[mqtt]\nurl = 'mqtt://broker'\nqos = 1\n", ":18: mqtt.qos: unknown table or key 'qos'"),
        ("[postgres]\ndsn = 'host=db port'\n", ":17: postgres.dsn: not a valid connection"),
        (
            "[postgres]\ndsn = 'postgresql://x'\nbogus = 1\n",
            ":18: postgres.bogus: unknown table or key",
        ),
    ],
)
def test_check_finds_what_a_start_would(tmp_path: Path, sink: str, message: str) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(GOOD + "\n" + sink)
    for args in (["--check"], []):  # --check says what the real start says, and exits 2 too
        done = subprocess.run(
            [*CLI, "collect", *args, str(path)], capture_output=True, text=True, timeout=30
        )
        assert done.returncode == 2, (args, done.stdout, done.stderr)
        assert f"{path}{message}" in done.stderr, done.stderr
    assert not (tmp_path / "data").exists()  # a bad sink table creates no store


def test_check_refuses_a_store_a_start_would_refuse(tmp_path: Path) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(GOOD)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "store.sqlite").write_bytes(b"not a database at all" * 100)
    done = subprocess.run(
        [*CLI, "collect", "--check", str(path)], capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 2, done.stdout
    assert "store.sqlite is not a collector store" in done.stderr
    (tmp_path / "data" / "store.sqlite").unlink()
    done = subprocess.run(
        [*CLI, "collect", "--check", str(path)], capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "data" / "store.sqlite").exists()  # --check creates nothing
