"""Station files: an ALA1 logger's whole configuration as TOML (docs/config.md).

A station file names settings the way the manual groups them (``[channel.3]``
``sampling_period = "000100"``, :mod:`sondalog.client.station_schema`), never by parameter
path. A setting left out is at its factory value (§11): the file is the whole configuration.
Conversion tables (§10) are files beside it, named in ``[tables]`` (``Tlevel =
"station.tables/Tlevel.txt"``); without a ``[tables]`` table a logger's tables are left alone.

:func:`read_station` reads one through :mod:`sondalog.config` (every error is
``FILE:LINE: field: message``, unknown keys are refused with a "did you mean") and checks
every value against the logger's grammar before anything is written; :func:`render_station`
writes one (``logger config pull``).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.client.station_grammar import (
    LIMITS,
    TOTAL_MEMORY,
    ChannelAddress,
    Limits,
    fits_line,
)
from sondalog.client.station_schema import GROUP_SECTIONS, INDEX, SETTINGS, Setting
from sondalog.config import ConfigError, Table
from sondalog.protocol.tables import TableError, build_files, parse_table

#: Keys of a station besides its setting groups.
META_KEYS = ("protocol", "serial_number", "tables")
MAX_TABLE_NAME = 10


@dataclass
class Station:
    """The settings a file gives (logger names -> canonical values) and where each is."""

    protocol: str | None = None
    serial_number: str | None = None
    values: dict[str, str] = field(default_factory=dict)
    tables: dict[str, Path] | None = None  # None: the file leaves the tables alone
    origin: dict[str, tuple[Table, str]] = field(default_factory=dict)

    def fail(self, name: str, message: str) -> ConfigError:
        """The error for setting ``name`` at its file, line and field."""
        table, key = self.origin[name]
        return table.fail(key, message)

    def merged(self, other: Station) -> Station:
        """``other``'s settings over this one's (a fleet entry over its template)."""
        tables = other.tables if other.tables is not None else self.tables
        return Station(
            other.protocol or self.protocol,
            other.serial_number or self.serial_number,
            {**self.values, **other.values},
            tables,
            {**self.origin, **other.origin},
        )

    def table_bodies(self) -> dict[str, bytes] | None:
        if self.tables is None:
            return None
        return {name: path.read_bytes() for name, path in self.tables.items()}


def _keys(setting: Setting) -> tuple[str, ...]:
    return (setting.key, setting.key + "_2") if setting.dual else (setting.key,)


def _group_settings(group: str) -> list[Setting]:
    return [s for s in SETTINGS if s.group == group]


def _value(table: Table, key: str, setting: Setting, limits: Limits) -> str:
    grammar = setting.grammar
    if grammar.toml_int and not (isinstance(grammar, ChannelAddress) and table.is_text(key)):
        text = str(table.integer(key))
    else:
        text = table.text(key, empty=True)
    try:
        return grammar.check(text, limits)
    except ValueError as exc:
        raise table.fail(key, str(exc)) from None


def _read_settings(
    table: Table, settings: list[Setting], n: int, limits: Limits, station: Station
) -> None:
    for setting in settings:
        given = [k for k in _keys(setting) if k in table]
        if not given:
            continue
        if setting.dual:
            assert isinstance(setting.default, str)  # inputs have fixed factory values
            first = setting.default
            if setting.key in table:
                first = _value(table, setting.key, setting, limits)
            second = first
            if setting.key + "_2" in table:
                second = _value(table, setting.key + "_2", setting, limits)
            value = f"{first},{second}"
        else:
            value = _value(table, setting.key, setting, limits)
        name = setting.name(n)
        write = f"write {name}{' all' if setting.dual else ''}{setting.grammar.written(value)}"
        problem = fits_line(write)
        if problem:
            raise table.fail(given[0], problem)
        station.values[name] = value
        station.origin[name] = (table, given[0])


def _read_group(root: Table, group: str, limits: Limits, station: Station) -> None:
    path = group.split(".")
    if path[0] not in root:
        return
    table = root.table(path[0])
    for part in path[1:]:
        table = table.table(part)
    settings = _group_settings(group)
    scalars = [s for s in settings if s.pattern.find("{") < 0]
    known = {k for s in scalars for k in _keys(s)}
    if group == "com":
        known.add("network")
    if group in INDEX:
        count = INDEX[group][1](limits)
        numbers = [str(n) for n in range(1, count + 1)]
        table.keys([*known, *numbers])
        numbered = [s for s in settings if s not in scalars]
        member_keys = [k for s in numbered for k in _keys(s)]
        for number in numbers:
            if number in table:
                member = table.table(number, member_keys)
                _read_settings(member, numbered, int(number), limits, station)
    else:
        table.keys(known)
    _read_settings(table, scalars, 1, limits, station)


def read_station(root: Table, *, extra_keys: tuple[str, ...] = (), check: bool = True) -> Station:
    """The station of ``root`` (a file's root table or a fleet entry), every value checked
    against the grammar of its protocol (``protocol``, default 2.10; spec notes §5);
    ``check``: also the memory partition (:func:`check_partition`; a fleet entry is checked
    once merged with its template)."""
    groups = sorted({s.group.split(".")[0] for s in SETTINGS})
    root.keys([*META_KEYS, *groups, *extra_keys])
    station = Station()
    station.protocol = root.opt_text("protocol", choices=tuple(LIMITS))
    station.serial_number = root.opt_text("serial_number")
    limits = LIMITS[station.protocol or "2.10"]
    for group in GROUP_SECTIONS:
        _read_group(root, group, limits, station)
    if "tables" in root:
        station.tables = _read_tables(root.table("tables"))
    if check:
        check_partition(station, root)
    return station


def check_partition(station: Station, where: Table) -> None:
    """§6.15: the three areas fit the memory, and the tables fit theirs (``where``: the
    table an error names when no size is given)."""
    names = ("file record size", "file list size", "file data size")
    defaults = (str(TOTAL_MEMORY), "0", "0")
    sizes = [int(station.values.get(n, d)) for n, d in zip(names, defaults, strict=True)]
    given = [n for n in names if n in station.values]
    if given and sum(sizes) > TOTAL_MEMORY:
        raise station.fail(
            given[-1], f"the areas take {sum(sizes)} bytes; the memory has {TOTAL_MEMORY} (§6.15)"
        )
    bodies = station.table_bodies()
    if not bodies:
        return
    for name, need, have in zip(names[1:], build_files(bodies), sizes[1:], strict=True):
        if len(need) > have:
            what = f"the tables need {len(need)} bytes of {name}, which is {have} (§6.15)"
            key = "tables" if "tables" in where else None
            raise station.fail(name, what) if name in station.values else where.fail(key, what)


def _read_tables(table: Table) -> dict[str, Path]:
    tables: dict[str, Path] = {}
    for name in table:
        if not 0 < len(name) <= MAX_TABLE_NAME or " " in name or not name.isascii():
            raise table.fail(name, f"a table name is 1 to {MAX_TABLE_NAME} ASCII characters")
        path = table.path(name)
        try:
            body = path.read_bytes()
        except OSError as exc:
            raise table.fail(name, f"cannot read {path}: {exc.strerror}") from None
        try:
            parse_table(body.decode("latin-1"))
        except TableError as exc:
            raise table.fail(name, f"{path}: {exc}") from None
        tables[name] = path
    return tables


# -- writing a station file ------------------------------------------------------------------


def _toml(setting: Setting, value: str) -> str:
    if setting.grammar.toml_int and value.isdigit() and int(value) < 2**63:
        return value
    return json.dumps(value)


def _lines(settings: list[Setting], n: int, values: Mapping[str, str], keep: set[str]) -> list[str]:
    out = []
    for setting in settings:
        name = setting.name(n)
        if name not in keep:
            continue
        value = values[name]
        comment = f"  # §{setting.section}"
        if setting.dual:
            first, second = value.split(",")
            out.append(f"{setting.key} = {_toml(setting, first)}{comment}")
            if second != first:
                out.append(f"{setting.key}_2 = {_toml(setting, second)}  # second input, §6.5.12.2")
        else:
            out.append(f"{setting.key} = {_toml(setting, value)}{comment}")
    return out


def render_station(
    values: Mapping[str, str],
    keep: set[str],
    *,
    protocol: str,
    serial: str,
    tables: Mapping[str, str] | None = None,
) -> str:
    """A station file of the settings named in ``keep`` (``values``: every setting of the
    logger), grouped and commented as the manual explains them; ``tables``: name -> path."""
    limits = LIMITS[protocol]
    out = [
        f"# ALA1 station file of logger {serial} (docs/config.md).",
        "# sondalog logger config plan|apply URL FILE: settings not written here are at their",
        "# factory values (§11). Groups and comments name the manual's sections.",
        f'protocol = "{protocol}"',
    ]
    for group, (section, title) in GROUP_SECTIONS.items():
        settings = _group_settings(group)
        scalars = [s for s in settings if "{" not in s.pattern]
        body = _lines(scalars, 1, values, keep)
        blocks: list[tuple[str, list[str]]] = [(group, body)] if body else []
        if group in INDEX:
            numbered = [s for s in settings if s not in scalars]
            for n in range(1, INDEX[group][1](limits) + 1):
                lines = _lines(numbered, n, values, keep)
                if lines:
                    blocks.append((f"{group}.{n}", lines))
        if not blocks:
            continue
        out.append("")
        out.append(f"# §{section} {title}")
        for header, lines in blocks:
            out.append(f"[{header}]")
            out.extend(lines)
    if tables:
        out += ["", "# §10 conversion tables: name = file (pulled by XMODEM, §6.16)", "[tables]"]
        for name, path in tables.items():
            key = name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name)
            out.append(f"{key} = {json.dumps(path)}")
    return "\n".join(out) + "\n"
