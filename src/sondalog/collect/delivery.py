"""What a collector source is to the runner: :class:`Source` makes one contact per
:meth:`~Source.poll` and hands its readings to a :data:`Deliver` callback. Below both the
download sources (:mod:`sondalog.collect.sources`) and the message sources
(:mod:`sondalog.collect.message_sources`)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Protocol

from sondalog.collect.config import SourceConfig

#: ``deliver(source name, batch, cursor, **source state columns)``
Deliver = Callable[..., Awaitable[None]]


class Source(Protocol):
    config: SourceConfig

    async def poll(self, deliver: Deliver) -> str:
        """One contact; returns a one-line summary for the log and the events table."""
        ...


#: ``channel type`` (§6.5.6) -> the ``sources`` column its newest reading fills.
GSM_TYPES = {12: "signal", 11: "credit"}
