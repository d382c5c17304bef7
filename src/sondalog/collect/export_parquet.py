"""Parquet export (the optional extra ``sondalog[parquet]``, i.e. pyarrow).

A Parquet file cannot be appended to: the readings of a download are kept in memory and
:meth:`ParquetExport.close` rewrites the whole file (the rows it had, then the new ones) into a
temporary file that is renamed over it, so the file is always either the old or the new one.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

from sondalog.client.records import make_key
from sondalog.collect.export_file import ExportError, as_record, note_appended
from sondalog.collect.model import Reading
from sondalog.collect.schema import COLUMNS


def _pyarrow() -> tuple[Any, Any]:
    try:
        import pyarrow as pa  # type: ignore[import-untyped]
        import pyarrow.parquet as pq  # type: ignore[import-untyped]
    except ImportError:
        raise ExportError(
            "Parquet needs pyarrow: pip install 'sondalog[parquet]' (or write .csv / .jsonl)"
        ) from None
    return pa, pq


def _schema(pa: Any) -> Any:
    return pa.schema(
        [
            ("logger", pa.string()),
            ("time", pa.string()),
            ("counter", pa.int8()),
            ("type", pa.int8()),
            ("channel", pa.int16()),
            ("value", pa.float64()),
            ("text", pa.string()),
            ("name", pa.string()),
            ("unit", pa.string()),
            ("utc", pa.string()),
        ]
    )


class ParquetExport:
    """An export to ``path`` (``.parquet``), written when closed."""

    def __init__(self, path: Path) -> None:
        self._pa, self._pq = _pyarrow()
        self.path = path
        self.logger: str | None = None
        self.cursor: str | None = None
        self.repaired: str | None = None
        self.rows = 0
        self.held_last: frozenset[tuple[str, int]] = frozenset()
        self._old: Any = None
        self._new: list[dict[str, Any]] = []
        if path.exists() and path.stat().st_size > 0:
            self._load()

    def _load(self) -> None:
        try:
            table = self._pq.read_table(self.path)
        except (OSError, self._pa.ArrowException) as exc:
            raise ExportError(f"{self.path} is not a Parquet file: {exc}") from None
        if tuple(table.column_names)[: len(COLUMNS)] != COLUMNS:
            raise ExportError(
                f"{self.path} is not a sondalog export (columns {table.column_names[:6]}): "
                "refusing to append"
            )
        self._old = table.select(list(COLUMNS)).cast(_schema(self._pa))
        if table.num_rows:
            tail = table.slice(max(0, table.num_rows - 200)).to_pylist()
            keys = [
                (make_key(datetime.fromisoformat(r["time"]), int(r["counter"])), r["channel"])
                for r in tail
            ]
            self.logger = tail[-1]["logger"]
            self.cursor = keys[-1][0]
            self.held_last = frozenset(k for k in keys if k[0] == self.cursor)

    def append(self, readings: Sequence[Reading]) -> None:
        self._new.extend(as_record(r) for r in readings)
        self.rows += len(readings)
        if readings:
            note_appended(self, readings)

    def close(self) -> None:
        """Write the file (old rows, then new ones) atomically; nothing new: untouched."""
        if not self._new and self.path.exists():
            return
        pa, pq = self._pa, self._pq
        table = pa.Table.from_pylist(self._new, schema=_schema(pa))
        if self._old is not None:
            table = pa.concat_tables([self._old, table])
        tmp = self.path.with_name(f".{self.path.name}.tmp")
        pq.write_table(table, tmp)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, self.path)
        self._new = []
