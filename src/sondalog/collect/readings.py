"""Record rows -> readings (the pure row pipeline of the collector, spec notes §6).

Each non-empty channel field of a row gives one :class:`~sondalog.collect.model.Reading`; an
empty field (no valid value, or a channel not sampled in that row) gives none. A text row gives
one reading on channel 0 with ``value`` None and the text in ``text``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from zoneinfo import ZoneInfo

from sondalog.client.records import Channel, Row, to_utc
from sondalog.collect.model import Reading


def readings(
    row: Row,
    logger: str,
    channels: Mapping[int, Channel] | None = None,
    zone: ZoneInfo | None = None,
) -> list[Reading]:
    """The readings of one row; ``zone`` (the logger's time zone) fills ``utc``."""
    utc = to_utc(row.time, zone) if zone is not None else None
    if row.text is not None:
        return [Reading(logger, 0, row.time, row.counter, row.type, None, row.text, utc=utc)]
    out: list[Reading] = []
    names = channels or {}
    for index, value in enumerate(row.values, start=1):
        if value is None:
            continue
        channel = names.get(index)
        out.append(
            Reading(
                logger,
                index,
                row.time,
                row.counter,
                row.type,
                value,
                None,
                channel.name if channel and channel.name else None,
                channel.unit if channel else None,
                utc,
            )
        )
    return out


def rows_to_readings(
    rows: Iterable[Row],
    logger: str,
    channels: Mapping[int, Channel] | None = None,
    zone: ZoneInfo | None = None,
) -> list[Reading]:
    """The readings of several rows, in row order."""
    out: list[Reading] = []
    for row in rows:
        out.extend(readings(row, logger, channels, zone))
    return out
