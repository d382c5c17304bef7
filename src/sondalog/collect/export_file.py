"""What every export file is (:class:`ExportFile`), its error and the record of a reading:
shared by the line formats (:mod:`sondalog.collect.export`) and Parquet
(:mod:`sondalog.collect.export_parquet`), below both."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from sondalog.client.records import make_key
from sondalog.collect.model import Reading, utc_text


class ExportError(Exception):
    """The file cannot be used (not an export of ours, another logger's, unreadable)."""


class ExportFile(Protocol):
    path: Path
    logger: str | None
    """The logger whose rows the file holds (None: a new, empty file)."""
    cursor: str | None
    """The record point of the last row the file holds."""
    repaired: str | None
    """What was cut from a torn file on opening (None: nothing)."""
    rows: int
    """Readings appended since opening."""
    held_last: frozenset[tuple[str, int]]
    """``(record point, channel)`` of the lines the file holds of its last row."""

    def append(self, readings: Sequence[Reading]) -> None: ...

    def close(self) -> None: ...


def as_record(r: Reading) -> dict[str, Any]:
    return {
        "logger": r.logger,
        "time": r.time.isoformat(timespec="seconds"),
        "counter": r.counter,
        "type": r.type,
        "channel": r.channel,
        "value": r.value,
        "text": r.text,
        "name": r.name,
        "unit": r.unit,
        "utc": utc_text(r.utc),
    }


def note_appended(export: ExportFile, readings: Sequence[Reading]) -> None:
    """Point ``export``'s logger, cursor and held_last at the last row of ``readings``."""
    export.logger = readings[-1].logger
    export.cursor = cursor = make_key(readings[-1].time, readings[-1].counter)
    export.held_last = frozenset(
        (make_key(r.time, r.counter), r.channel)
        for r in readings
        if make_key(r.time, r.counter) == cursor
    )


def check_logger(export: ExportFile, logger: str) -> None:
    """Refuse to mix loggers in one file."""
    if export.logger is not None and export.logger != logger:
        raise ExportError(
            f"{export.path} holds the rows of logger {export.logger!r}, "
            f"not of this logger ({logger!r}): choose another file"
        )
