"""``expect = "station.toml"`` on a collector's logger source (issue 22): the station file
the logger should match, read when the collector's file is (errors name the station file's
file, line and field; a missing file names the source's ``expect``).

A file with ``[[logger]]`` entries (a fleet, docs/config.md) gives the entry whose ``url`` is
the source's; a single-logger file applies as it is.
"""

from __future__ import annotations

from pathlib import Path

from sondalog.client.station_file import Station
from sondalog.client.station_fleet import read_file
from sondalog.config import Table


def read_expect(t: Table, url: str) -> tuple[Station, Path] | None:
    """The station a ``[[source]]`` table's ``expect`` names (for the logger at ``url``)."""
    path = t.opt_path("expect")
    if path is None:
        return None
    if not path.is_file():
        raise t.fail("expect", f"{path}: no such station file")
    targets = read_file(path)
    if len(targets) == 1 and targets[0].url is None:
        return targets[0].station, path
    for target in targets:
        if target.url == url:
            return target.station, path
    raise t.fail("expect", f"{path} has no [[logger]] with url = {url!r}")
