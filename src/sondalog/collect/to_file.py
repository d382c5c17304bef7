"""Download a logger's new rows into an export file (the work behind ``logger download``).

Connect, :meth:`~sondalog.client.download.Download.identify` the logger (serial number, clock,
channel names), check that the file belongs to it, then append every verified chunk's readings
to the file. The download starts at the last row the file holds, which is read again: lines
of it that a crash kept out of the file are added, the others skipped. See
:mod:`sondalog.collect.export`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from zoneinfo import ZoneInfo

from sondalog.client import Ala1Client
from sondalog.client.download import Chunk, Download, Gap, LoggerInfo
from sondalog.client.records import make_key
from sondalog.collect.export import ExportFile, check_logger, open_export
from sondalog.collect.readings import rows_to_readings


@dataclass
class FileDownload:
    """What a download did so far (kept up to date, so an interrupted one can report it)."""

    path: Path
    info: LoggerInfo | None = None
    rows: int = 0
    readings: int = 0
    bytes: int = 0
    rereads: int = 0
    gaps: list[Gap] = field(default_factory=list)
    repaired: str | None = None
    resumed_after: str | None = None
    cursor: str | None = None
    record_empty: bool = False


async def download_to_file(
    url: str,
    path: Path,
    *,
    zone: ZoneInfo | None = None,
    timeout: float = 5.0,
    state: FileDownload | None = None,
    on_chunk: Callable[[FileDownload, Chunk], None] | None = None,
    on_gap: Callable[[Gap], None] | None = None,
) -> FileDownload:
    """Append the logger's rows after the file's last row to ``path``; returns what it did.

    Raises :class:`~sondalog.collect.export.ExportError` for a file that is not ours (nothing
    is written to it), :class:`~sondalog.client.download.DownloadError` and the client's
    errors (``OSError`` when unreachable, :class:`~sondalog.client.ClientError`) for the line.
    """
    done = state or FileDownload(path)
    export: ExportFile = open_export(path)
    try:
        done.repaired = export.repaired
        done.resumed_after = done.cursor = export.cursor
        client = await Ala1Client.connect(url, timeout=timeout)
        try:
            download = Download(
                client, after=export.cursor, zone=zone, include_after=export.cursor is not None
            )
            held = export.held_last
            info = done.info = await download.identify()
            check_logger(export, info.snumber)
            async for chunk in download.chunks():
                if chunk.gap is not None:
                    done.gaps.append(chunk.gap)
                    if on_gap is not None:
                        on_gap(chunk.gap)
                batch = rows_to_readings(chunk.rows, info.snumber, info.channels, zone)
                if held:  # the last row held is read again: add only the lines missing
                    batch = [
                        r for r in batch if (make_key(r.time, r.counter), r.channel) not in held
                    ]
                    held = frozenset()
                export.append(batch)
                done.rows += sum(1 for row in chunk.rows if row.key > (done.resumed_after or ""))
                done.readings += len(batch)
                done.bytes += chunk.bytes
                done.rereads += chunk.rereads
                done.cursor = chunk.cursor or done.cursor
                if on_chunk is not None:
                    on_chunk(done, chunk)
            done.record_empty = download.record_empty
        finally:
            await client.close()
    finally:
        export.close()
    return done
