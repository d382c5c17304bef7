"""A signal's points (:mod:`.signals`): a ``steps`` schedule's ``[time, value]`` pairs from
its table, or a ``csv`` model's ``time,value`` rows from its file; a bad one raises
:class:`~sondalog.config.ConfigError` naming the field (or the file and line)."""

from __future__ import annotations

import csv
from pathlib import Path

from sondalog.config import ConfigError

__all__ = ["points", "read_csv_points"]


def _pair(value: object) -> tuple[float, float] | None:
    """``[time, value]``, two numbers (not true/false), or ``None``."""
    match value:
        case [bool(), _] | [_, bool()]:
            return None
        case [int() | float() as time, int() | float() as number]:
            return float(time), float(number)
    return None


def points(raw: object, field: str) -> list[tuple[float, float]]:
    """Ascending ``[time, value]`` pairs (the reader has no getter for an array of arrays:
    this is its one local stand-in)."""
    match raw:
        case [*items] if items:
            pass
        case _:
            raise ConfigError(None, field, "must be a non-empty list of [time, value] pairs")
    points: list[tuple[float, float]] = []
    for i, item in enumerate(items):
        where = f"{field}[{i}]"
        pair = _pair(item)
        if pair is None:
            raise ConfigError(None, where, f"must be a [time, value] pair of numbers, not {item!r}")
        if points and pair[0] <= points[-1][0]:
            raise ConfigError(None, where, "times must be strictly ascending")
        points.append(pair)
    return points


def read_csv_points(path: Path) -> list[tuple[float, float]]:
    """``time,value`` rows of a CSV file (an optional header line is skipped)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(None, "path", f"cannot read {path}: {exc.strerror or exc}") from exc
    rows: list[list[float]] = []
    for lineno, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            continue
        try:
            rows.append([float(row[0]), float(row[1])])
        except (ValueError, IndexError):
            if lineno == 1 and not rows:
                continue  # header
            raise ConfigError(None, "path", f"{path} line {lineno}: expected time,value") from None
    if not rows:
        raise ConfigError(None, "path", f"{path} holds no time,value rows")
    try:
        return points(rows, "path")
    except ConfigError as exc:
        raise ConfigError(None, "path", f"{path}: {exc.message}") from None
