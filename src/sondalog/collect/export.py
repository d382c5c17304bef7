"""Export files of readings: CSV (long form), JSON lines and Parquet, appended on every run.

Every format holds the columns ``logger,time,counter,type,channel,value,text,name,unit,utc``
(see :mod:`sondalog.collect.schema`): one line per reading, text rows with their text. A file
tells which logger it belongs to and which row it holds last, so a download resumes from it
(:attr:`ExportFile.cursor`) and refuses a file that is not an export of the same logger.

CSV and JSON lines are appended chunk by chunk: each chunk is one write followed by ``fsync``,
so an interrupted download leaves a valid file. A crash in the middle of a write can leave a
torn last line, which opening the file cuts (:attr:`ExportFile.repaired`), or end the file
between two lines of one row: the download therefore reads the last row held again and adds
the lines of it the file lacks (:attr:`ExportFile.held_last`). Parquet files cannot be appended
to: the new readings are kept in memory and the whole file is rewritten atomically (a
temporary file renamed over it) when the export is closed.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path

from sondalog.client.records import COUNTERS, make_key
from sondalog.collect.export_file import ExportError as ExportError
from sondalog.collect.export_file import ExportFile as ExportFile
from sondalog.collect.export_file import as_record, note_appended
from sondalog.collect.export_file import check_logger as check_logger
from sondalog.collect.export_parquet import ParquetExport
from sondalog.collect.model import Reading
from sondalog.collect.schema import COLUMNS

CSV_HEADER = ",".join(COLUMNS)
_TAIL = 256 * 1024


def open_export(path: Path) -> ExportFile:
    """The export at ``path`` by its suffix: ``.csv``, ``.jsonl`` (``.ndjson``), ``.parquet``."""
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return CsvExport(path)
    if suffix in (".jsonl", ".ndjson"):
        return JsonlExport(path)
    if suffix == ".parquet":
        return ParquetExport(path)
    raise ExportError(
        f"{path}: unknown format {suffix or '(no suffix)'!r}: use .csv, .jsonl or .parquet"
    )


class _LineExport:
    """Shared by CSV and JSON lines: one line per reading, appended with fsync per chunk."""

    kind = ""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.logger: str | None = None
        self.cursor: str | None = None
        self.repaired: str | None = None
        self.rows = 0
        self.held_last: frozenset[tuple[str, int]] = frozenset()
        try:
            self._file = open(path, "a+b")  # noqa: SIM115 - kept open across chunks
        except OSError as exc:
            raise ExportError(f"{path}: cannot open: {exc.strerror or exc}") from exc
        try:
            self._load()
        except BaseException:
            self._file.close()
            raise

    # subclasses: the header (or b""), whether a first line is ours, one line -> (logger, key)
    def _header(self) -> bytes:
        return b""

    def _is_ours(self, first: bytes) -> bool:
        raise NotImplementedError

    def _key(self, line: bytes) -> tuple[str, str, int]:
        """``(logger, record point, channel)`` of one line."""
        raise NotImplementedError

    def _torn_start(self, first: bytes) -> bool:
        """Whether ``first`` (no line end) is the start of a file of ours cut by a crash."""
        raise NotImplementedError

    def _encode(self, readings: Sequence[Reading]) -> bytes:
        raise NotImplementedError

    def _load(self) -> None:
        f = self._file
        size = f.seek(0, os.SEEK_END)
        if size == 0:
            self._write(self._header())
            return
        f.seek(0)
        first = f.readline()
        if not first.endswith(b"\n") and self._torn_start(first):
            f.truncate(0)  # a crash during the very first write: start afresh
            self.repaired = f"a torn first line ({len(first)} bytes)"
            self._write(self._header())
            return
        if not self._is_ours(first):
            raise ExportError(
                f"{self.path} is not a sondalog {self.kind} export (its first line is "
                f"{first[:60].decode('latin-1', 'replace').rstrip()!r}): refusing to append"
            )
        header = len(first) if self._header() else 0
        if header and not first.endswith(b"\n"):
            self._write(b"\n")  # a header cut right before its line end
            return
        start = max(header, size - _TAIL)
        f.seek(start)
        tail = f.read()
        if start > header:  # the block starts inside a line: skip to the next one
            cut = tail.find(b"\n") + 1
            start, tail = start + cut, tail[cut:]
        keep = len(tail)
        if tail and not tail.endswith(b"\n"):
            keep = tail.rfind(b"\n") + 1
            self.repaired = f"a torn last line ({len(tail) - keep} bytes)"
        lines = tail[:keep].splitlines(keepends=True)
        keys: list[tuple[str, str, int]] = []
        for line in lines:
            try:
                keys.append(self._key(line))
            except (ValueError, KeyError, IndexError, TypeError) as exc:
                raise ExportError(f"{self.path}: unreadable line {line[:80]!r}: {exc}") from None
        if keep != len(tail):
            f.truncate(start + keep)
            f.flush()
            os.fsync(f.fileno())
        if keys:
            self.logger, self.cursor, _ = keys[-1]
            self.held_last = frozenset(
                (key, channel) for _, key, channel in keys if key == self.cursor
            )

    def _write(self, data: bytes) -> None:
        if not data:
            return
        self._file.seek(0, os.SEEK_END)
        self._file.write(data)
        self._file.flush()
        os.fsync(self._file.fileno())

    def append(self, readings: Sequence[Reading]) -> None:
        """Append one chunk (one write, then fsync)."""
        if not readings:
            return
        self._write(self._encode(readings))
        self.rows += len(readings)
        note_appended(self, readings)

    def close(self) -> None:
        self._file.close()


class CsvExport(_LineExport):
    """CSV in long form, header ``logger,time,counter,type,channel,value,text,name,unit,utc``."""

    kind = "CSV"

    def _header(self) -> bytes:
        return (CSV_HEADER + "\n").encode()

    def _is_ours(self, first: bytes) -> bool:
        return first.rstrip(b"\r\n") == CSV_HEADER.encode()

    def _torn_start(self, first: bytes) -> bool:
        return CSV_HEADER.encode().startswith(first) and first != CSV_HEADER.encode()

    def _key(self, line: bytes) -> tuple[str, str, int]:
        fields = next(csv.reader([line.decode("utf-8")]))
        time = datetime.fromisoformat(fields[1])
        return fields[0], make_key(time, int(fields[2])), int(fields[4])

    def _encode(self, readings: Sequence[Reading]) -> bytes:
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerows(as_record(r).values() for r in readings)
        return out.getvalue().encode("utf-8")


class JsonlExport(_LineExport):
    """JSON lines: one object per reading with the CSV's columns as keys."""

    kind = "JSON lines"

    def _torn_start(self, first: bytes) -> bool:
        return first.startswith(b'{"logger": ') or b'{"logger": '.startswith(first)

    def _is_ours(self, first: bytes) -> bool:
        try:
            record = json.loads(first)
        except ValueError:
            return False
        return isinstance(record, dict) and tuple(record)[: len(COLUMNS)] == COLUMNS

    def _key(self, line: bytes) -> tuple[str, str, int]:
        record = json.loads(line)
        counter = int(record["counter"])
        if not 0 <= counter < len(COUNTERS):
            raise ValueError(f"counter {counter}")
        time = datetime.fromisoformat(record["time"])
        return str(record["logger"]), make_key(time, counter), int(record["channel"])

    def _encode(self, readings: Sequence[Reading]) -> bytes:
        return "".join(
            json.dumps(as_record(r), ensure_ascii=False) + "\n" for r in readings
        ).encode("utf-8")
