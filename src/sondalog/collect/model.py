"""What flows through the collector: readings from sources to sinks (the pure row pipeline).

A :class:`Reading` is one value of one channel in one record row (§6.8: a row
``YYYYMMDDhhmmss.c,t,f1,...,fn`` gives one reading per non-empty channel field, and a text row
gives one reading on channel 0). Its identity is ``(logger, time, counter, channel)``: sinks
insert idempotently on it, so a row seen twice is stored once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Protocol, runtime_checkable


@dataclass(frozen=True, slots=True)
class Reading:
    """One reading, as the store keeps it (see :mod:`sondalog.collect.schema`)."""

    logger: str
    channel: int
    time: datetime  # naive: the logger's own clock
    counter: int
    type: int
    value: float | None
    text: str | None = None
    name: str | None = None
    unit: str | None = None
    utc: datetime | None = None  # aware (UTC) when the logger's time zone is known

    @property
    def key(self) -> tuple[str, str, int, int]:
        """The identity every sink deduplicates on."""
        return (self.logger, self.time.isoformat(timespec="seconds"), self.counter, self.channel)


def utc_text(utc: datetime | None) -> str | None:
    """``2007-03-01T11:00:00Z``: the one spelling of ``utc`` in every store, file and message."""
    return None if utc is None else utc.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


class SinkUnavailable(Exception):
    """The sink cannot take writes now (database or broker down): buffer and retry later."""


class Sink(Protocol):
    """A destination of readings, registered by name (``sqlite``, ``postgres``, ``mqtt``...).

    ``write`` is idempotent on :attr:`Reading.key` and either stores the whole batch or raises
    :class:`SinkUnavailable` (nothing half-written that a retry would duplicate).
    """

    name: str

    async def open(self) -> None: ...

    async def write(self, batch: Sequence[Reading]) -> None: ...

    async def close(self) -> None: ...


@runtime_checkable
class Announcing(Protocol):
    """A sink that tells its readers whether the collector is running (MQTT availability).

    ``stay_online`` (set by ``collect --once``): a clean close leaves the collector
    ``online``, as runs from cron come and go; a collector that dies still goes ``offline``.
    """

    stay_online: bool
