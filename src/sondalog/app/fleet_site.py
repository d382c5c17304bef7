"""The ``[[loggers]]`` of a site file: a fleet of virtual loggers in one process (issue 11).

Each entry is one logger, or a numbered range of them::

    [[loggers]]                       # one logger
    serial_number = "A1-0001"
    listen = "127.0.0.1:11001"
    protocol = "2.10"                 # optional; fixed once its state exists
    site = "station.toml"             # optional: the simulated world of that file's [logger]

    [[loggers]]                       # a numbered range
    count = 1000
    first = 1                         # optional, default 1
    serial_number = "F{n:04}"         # {n} is the logger's number: F0001 ... F1000
    listen = "127.0.0.1:12000"        # the first's port; logger n listens on port + n - first

A serial number names the logger's state directory (``STATE/loggers/SERIAL``) and its log
lines, so it is made of letters, digits, ``-``, ``_`` and ``.``. Serial numbers are unique
across the file; so are ports, with every other listener of the file (``app.site`` checks them
all; port 0: each logger any free port). Errors name the file, the line
and the field (``loggers[1].listen``), like every site-file error.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from sondalog.config import ConfigError, locate
from sondalog.config.address import parse_listen

_Fail = Callable[[str, str], ConfigError]

#: The most loggers one site file may declare (docs/scaling.md: shard beyond that).
MAX_FLEET = 20_000
_KEYS = {"serial_number", "listen", "protocol", "site", "count", "first"}
_SERIAL = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,31}")


@dataclass(frozen=True)
class FleetLogger:
    """One logger of a fleet: its identity, where it listens, its world."""

    serial_number: str
    listen: tuple[str, int]
    protocol: str | None = None
    world: Path | None = None  # a site file whose [logger] is this logger's hardware
    where: str = "loggers[0]"  # the entry that declared it (for errors at start)


def parse_fleet(
    data: Mapping[str, object], path: Path | None, text: str | None
) -> list[FleetLogger]:
    """Every logger of the file's ``[[loggers]]`` (empty when it has none)."""

    def fail(where: str, message: str) -> ConfigError:
        return ConfigError(path, where, message, locate(text, where))

    raw = data.get("loggers")
    if raw is None:
        return []
    if not isinstance(raw, list) or not raw:
        raise fail("loggers", "must be an array of tables ([[loggers]])")
    fleet: list[FleetLogger] = []
    serials: dict[str, str] = {}
    for i, entry in enumerate(raw):
        where = f"loggers[{i}]"
        if not isinstance(entry, Mapping):
            raise fail(where, "must be a table")
        for logger in _entry(entry, where, path, fail):
            if len(fleet) >= MAX_FLEET:
                raise fail(where, f"more than {MAX_FLEET} loggers in one file: shard the fleet")
            if logger.serial_number in serials:
                raise fail(
                    f"{where}.serial_number",
                    f"{logger.serial_number} is also declared by {serials[logger.serial_number]}",
                )
            serials[logger.serial_number] = where
            fleet.append(logger)
    return fleet


def _entry(
    entry: Mapping[str, object], where: str, path: Path | None, fail: _Fail
) -> list[FleetLogger]:
    for key in entry:
        if key not in _KEYS:
            raise fail(f"{where}.{key}", f"unknown key (known: {', '.join(sorted(_KEYS))})")
    for key in ("serial_number", "listen"):
        if key not in entry:
            raise fail(f"{where}.{key}", "is required")
    count = _integer(entry.get("count", 1), f"{where}.count", 1, MAX_FLEET, fail)
    first = _integer(entry.get("first", 1), f"{where}.first", 0, 10**9, fail)
    pattern = entry["serial_number"]
    if not isinstance(pattern, str) or not pattern:
        raise fail(f"{where}.serial_number", "must be a non-empty string")
    if "count" in entry and "{n" not in pattern:
        raise fail(f"{where}.serial_number", "a numbered range needs {n} in its serial number")
    listen = entry["listen"]
    if not isinstance(listen, str):
        raise fail(f"{where}.listen", 'must be "HOST:PORT"')
    try:
        host, port = parse_listen(listen)
    except ValueError as exc:
        raise fail(f"{where}.listen", str(exc)) from None
    if port and port + count - 1 > 65535:
        raise fail(f"{where}.listen", f"ports {port}..{port + count - 1} go beyond 65535")
    protocol = entry.get("protocol")
    if protocol is not None and protocol not in ("1.16", "2.10"):
        raise fail(f"{where}.protocol", 'must be "1.16" or "2.10"')
    world = entry.get("site")
    if world is not None and (not isinstance(world, str) or not world):
        raise fail(f"{where}.site", "must be the path of a site file")
    world_path = None
    if isinstance(world, str):
        world_path = Path(world)
        if not world_path.is_absolute() and path is not None:
            world_path = path.parent / world_path
    loggers = []
    for n in range(first, first + count):
        serial = _serial(pattern, n, f"{where}.serial_number", fail)
        loggers.append(
            FleetLogger(
                serial, (host, port + n - first if port else 0), protocol, world_path, where
            )
        )
    return loggers


def _integer(value: object, where: str, low: int, high: int, fail: _Fail) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise fail(where, f"must be an integer from {low} to {high}, not {value!r}")
    return value


def _serial(pattern: str, n: int, where: str, fail: _Fail) -> str:
    try:
        serial = pattern.format(n=n)
    except (KeyError, IndexError, ValueError) as exc:
        raise fail(where, f"cannot number {pattern!r}: {exc} (use {{n}}, e.g. F{{n:04}})") from None
    if not _SERIAL.fullmatch(serial):
        raise fail(
            where,
            f"{serial!r}: 1 to 32 letters, digits, '-', '_' or '.' (it names a directory)",
        )
    return serial
