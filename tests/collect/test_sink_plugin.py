"""A sink is one module and one registration (issue 25): the JSON-lines sink below is defined
and registered here only, and a collector configured from TOML with its ``[jsonl]`` table
writes a served logger's readings through it; a bad ``[jsonl]`` table is refused with the
file, the line and the field."""

from __future__ import annotations

import asyncio
import contextlib
import json
import sqlite3
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest
from served_logger import configure, sampling_logger

from sondalog.collect.config import load_config
from sondalog.collect.model import Reading
from sondalog.collect.runner import Collector
from sondalog.collect.sinks import register_sink
from sondalog.config import ConfigError, Table


@dataclass(frozen=True, slots=True)
class JsonlConfig:
    path: Path
    pretty: bool


def parse_jsonl(table: Table) -> JsonlConfig:
    table.keys(("path", "pretty"))
    return JsonlConfig(table.path("path"), table.flag("pretty", False))


class JsonlSink:
    """One JSON object a line per reading, each key once."""

    name = "jsonl"

    def __init__(self, config: JsonlConfig) -> None:
        self.config = config

    async def open(self) -> None:
        self.config.path.touch()

    async def write(self, batch: Sequence[Reading]) -> None:
        seen = {
            tuple(json.loads(line)["key"]) for line in self.config.path.read_text().splitlines()
        }
        with self.config.path.open("a") as out:
            for r in batch:
                if r.key not in seen:
                    out.write(json.dumps({"key": r.key, "value": r.value}) + "\n")

    async def close(self) -> None:
        pass


register_sink("jsonl", JsonlSink, parse_jsonl)


def _toml(url: str, sink: str) -> str:
    return f'[sqlite]\npath = "store.sqlite"\n\n[[source]]\nurl = "{url}"\ninterval = 1\n\n{sink}'


def test_a_registered_sink_is_configured_from_its_table(tmp_path: Path) -> None:
    out = tmp_path / "readings.jsonl"
    path = tmp_path / "collector.toml"
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.3)
        path.write_text(_toml(served.url, f'[jsonl]\npath = "{out}"\n'))
        config = load_config(path)
        assert config.sinks == {"jsonl": JsonlConfig(out, False)}
        collector = Collector(config)
        asyncio.run(collector.run(asyncio.Event(), once=True))
        assert not collector.failing, _events(tmp_path / "store.sqlite")
    written = {tuple(json.loads(line)["key"]) for line in out.read_text().splitlines()}
    with contextlib.closing(sqlite3.connect(tmp_path / "store.sqlite")) as db:
        stored = set(db.execute("SELECT logger, time, counter, channel FROM readings"))
    assert stored and written == stored


def _events(store: Path) -> list[tuple[str, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return list(db.execute("SELECT kind, text FROM events"))


@pytest.mark.parametrize(
    ("table", "where"),
    [
        ("[jsonl]\npath = 3\n", ":9: jsonl.path: must be a path"),
        ('[jsonl]\npath = "x"\npretty = "yes"\n', ":10: jsonl.pretty: must be true or false"),
        (
            '[jsonl]\npath = "x"\n\ncolour = 1\n',
            ":11: jsonl.colour: unknown table or key 'colour' (known: path, pretty)",
        ),
        ("[jsonl]\n", ":8: jsonl.path: required"),
    ],
)
def test_a_bad_table_of_it_names_file_line_and_field(
    tmp_path: Path, table: str, where: str
) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(_toml("tcp://127.0.0.1:10001", table))
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert f"{path}{where}" in str(caught.value)


def test_an_unknown_table_is_still_refused(tmp_path: Path) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(_toml("tcp://127.0.0.1:10001", '[kafka]\nbrokers = "x"\n'))
    with pytest.raises(
        ConfigError, match=r":8: kafka: unknown table or key 'kafka' \(known: .*jsonl.*mqtt"
    ):
        load_config(path)


def test_a_misspelt_sink_table_gets_a_did_you_mean(tmp_path: Path) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(_toml("tcp://127.0.0.1:10001", '[jsnol]\npath = "x"\n'))
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    assert str(caught.value).startswith(
        f"{path}:8: jsnol: unknown table or key 'jsnol' (did you mean jsonl? "
    )
