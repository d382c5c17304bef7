"""The progress of the reading rules' alarms, one row per logger (issue 21: the alarms at
ingest cost at most a tenth of the ingest).

Every reading a ``threshold``, ``stuck`` or ``step`` rule takes moves its alarm's progress
(``count``, ``last_value``, ``last_time``, ``last_counter``), and a restart must go on from
exactly there, so the progress is saved with every chunk of readings, in the transaction of
the chunk's transitions. Written as one ``UPDATE`` of ``alarm_states`` per alarm per chunk it
was most of the alarms' cost at ingest (the benchmark's 21,000 alarms, each its own row, in
its own place of the table); ``alarm_progress`` holds the progress of every reading alarm of
one logger in one row instead, written in place once per chunk (docs/alarms.md "The
schema", docs/decisions.md "Alarm progress, one row per logger").

The row's ``progress`` is a BLOB (PostgreSQL: ``bytea``) of one fixed entry of
:data:`ENTRY` (43 bytes, little-endian) per alarm: its id (10 ASCII bytes, NUL-padded), flags
(1: ``last_value`` known, 2: ``last_time`` known), ``count`` and ``last_counter`` (int64),
``last_value`` and ``last_time`` (float64, 0 when not known): floats as they are, so they
come back exactly. Packing it is a copy of numbers (a text form such as JSON spends most of
its time writing the floats out). When the states are loaded (:func:`overlay`) it wins over
the progress columns of ``alarm_states`` unless those are newer (a row written whole by a
version without ``alarm_progress``): those columns are written with a whole row only (a new
alarm, a change of state).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping

from .events import AlarmRecord

#: One alarm's entry: id, flags, count, last_counter, last_value, last_time.
ENTRY = "10sBqqdd"
#: The most bytes of an alarm id an entry holds (:func:`~.events.alarm_id` gives 10).
ID_BYTES = 10
_VALUE, _TIME = 1, 2
_entry = struct.Struct("<" + ENTRY)
_structs: dict[int, struct.Struct] = {}


def logger_of(subject: str) -> str:
    """The logger of a reading alarm's subject ``LOGGER/CHANNEL``: its row's key."""
    return subject.rpartition("/")[0]


def fits(alarm: str) -> bool:
    """Whether the id ``alarm`` fits an entry (every id :func:`~.events.alarm_id` makes)."""
    return len(alarm.encode()) <= ID_BYTES


def pack(alarms: Mapping[str, AlarmRecord]) -> bytes:
    """The ``progress`` of one logger's reading alarms (by id, each :func:`fits`)."""
    flat: list[object] = []
    add = flat.extend
    for alarm, r in alarms.items():
        value, time = r.last_value, r.last_time
        add(
            (
                alarm.encode(),
                (value is not None) | (time is not None) << 1,
                r.count,
                r.last_counter,
                0.0 if value is None else value,
                0.0 if time is None else time,
            )
        )
    packer = _structs.get(len(alarms))
    if packer is None:
        packer = _structs[len(alarms)] = struct.Struct("<" + ENTRY * len(alarms))
    return packer.pack(*flat)


def unpack(blob: bytes) -> dict[str, tuple[int, float | None, float | None, int]]:
    """What :func:`pack` packed: alarm -> (count, last_value, last_time, last_counter)."""
    out = {}
    for alarm, flags, count, counter, value, time in _entry.iter_unpack(bytes(blob)):
        out[alarm.rstrip(b"\0").decode()] = (
            count,
            value if flags & _VALUE else None,
            time if flags & _TIME else None,
            counter,
        )
    return out


def overlay(records: Iterable[AlarmRecord], rows: Iterable[tuple[str, bytes]]) -> None:
    """The progress of the ``alarm_progress`` ``rows`` (logger, progress) into the stored
    ``records`` (in place), where it is not older than theirs. A value comes back as a REAL
    column gives it back (NaN as None, -0.0 as 0.0), so both ways of storing agree."""
    by_id = {r.alarm: r for r in records}
    for _logger, blob in rows:
        for alarm, (count, value, time, counter) in unpack(blob).items():
            record = by_id.get(alarm)
            if record is None:
                continue  # its rule left the file
            last = record.last_time
            if last is not None and (time is None or (time, counter) < (last, record.last_counter)):
                continue  # the whole row is newer
            record.count = count
            record.last_value = _as_real(value)
            record.last_time = _as_real(time)
            record.last_counter = counter


def _as_real(value: float | None) -> float | None:
    """``value`` as SQLite gives a REAL back: NaN as NULL, -0.0 as 0.0."""
    return None if value is None or value != value else value + 0.0
