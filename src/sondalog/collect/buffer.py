"""A durable queue of reading batches per sink: what a sink could not take yet waits on disk.

The collector appends every batch for a sink to the buffer before it tries the sink and acks
it once the sink stored it. A database or broker that is down, or a ``kill -9`` at any moment,
then loses nothing: the next start replays the pending batches in the order they arrived.
Sinks insert idempotently on :attr:`~sondalog.collect.model.Reading.key`, so a batch that was
stored but not yet acked when the process died is stored once, not twice.

The buffer is one SQLite file in WAL mode with ``synchronous=FULL``: an append is on disk
when :meth:`DiskBuffer.append` returns (the principle "nothing acknowledged is lost").
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path

from sondalog.collect.model import Reading, Sink, SinkUnavailable
from sondalog.io.private import connect_private, private_parents

_DDL = """
CREATE TABLE IF NOT EXISTS pending (
    id    INTEGER PRIMARY KEY AUTOINCREMENT,
    sink  TEXT NOT NULL,
    batch TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS pending_sink ON pending (sink, id);
"""


def encode_batch(batch: Sequence[Reading]) -> str:
    """One batch as JSON text (a list of field lists, datetimes in ISO 8601)."""
    rows = [
        [
            r.logger,
            r.channel,
            r.time.isoformat(),
            r.counter,
            r.type,
            r.value,
            r.text,
            r.name,
            r.unit,
            None if r.utc is None else r.utc.isoformat(),
        ]
        for r in batch
    ]
    return json.dumps(rows, ensure_ascii=False, separators=(",", ":"), allow_nan=True)


def decode_batch(text: str) -> list[Reading]:
    """The inverse of :func:`encode_batch`."""
    out: list[Reading] = []
    for row in json.loads(text):
        logger, channel, time, counter, type_, value, txt, name, unit, utc = row
        out.append(
            Reading(
                logger=logger,
                channel=channel,
                time=datetime.fromisoformat(time),
                counter=counter,
                type=type_,
                value=None if value is None else float(value),
                text=txt,
                name=name,
                unit=unit,
                utc=None if utc is None else datetime.fromisoformat(utc),
            )
        )
    return out


class DiskBuffer:
    """An SQLite-backed durable FIFO of batches, one queue per sink name."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        private_parents(self.path)  # private, 0600, like the store (docs/security.md)
        self._db = connect_private(self.path)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.execute("PRAGMA busy_timeout=5000")
        self._db.executescript(_DDL)

    def append(self, sink_name: str, batch: Sequence[Reading]) -> int:
        """Queue ``batch`` for ``sink_name``; durable on return. Returns the batch's id."""
        cur = self._db.execute(
            "INSERT INTO pending (sink, batch) VALUES (?, ?)", (sink_name, encode_batch(batch))
        )
        assert cur.lastrowid is not None
        return cur.lastrowid

    def pending(self, sink_name: str, limit: int | None = None) -> list[tuple[int, list[Reading]]]:
        """The batches not yet acked for ``sink_name``, oldest first, as ``(id, batch)``."""
        sql = "SELECT id, batch FROM pending WHERE sink = ? ORDER BY id"
        args: tuple[object, ...] = (sink_name,)
        if limit is not None:
            sql += " LIMIT ?"
            args = (sink_name, limit)
        return [(i, decode_batch(b)) for i, b in self._db.execute(sql, args)]

    def ack(self, sink_name: str, batch_id: int) -> None:
        """The sink stored batch ``batch_id``: forget it (acking twice is harmless)."""
        self._db.execute("DELETE FROM pending WHERE sink = ? AND id = ?", (sink_name, batch_id))

    def count(self, sink_name: str) -> int:
        """How many batches wait for ``sink_name``."""
        row = self._db.execute("SELECT count(*) FROM pending WHERE sink = ?", (sink_name,))
        return int(row.fetchone()[0])

    def close(self) -> None:
        self._db.close()


async def drain(buffer: DiskBuffer, sink: Sink, sink_name: str | None = None) -> int:
    """Replay ``sink``'s pending batches in order until the queue is empty or the sink fails.

    Returns the number of batches delivered. A :class:`SinkUnavailable` stops the replay and
    leaves that batch (and all later ones) queued for the next call; the order is kept.
    """
    name = sink_name or sink.name
    done = 0
    while True:
        chunk = buffer.pending(name, limit=64)
        if not chunk:
            return done
        for batch_id, batch in chunk:
            try:
                await sink.write(batch)
            except SinkUnavailable:
                return done
            buffer.ack(name, batch_id)
            done += 1


async def deliver(
    buffer: DiskBuffer, sink: Sink, batch: Sequence[Reading], sink_name: str | None = None
) -> bool:
    """Queue ``batch`` durably, then replay the queue. True when nothing is left waiting."""
    buffer.append(sink_name or sink.name, batch)
    await drain(buffer, sink, sink_name)
    return buffer.count(sink_name or sink.name) == 0
