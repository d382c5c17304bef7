"""The buckets of a plan as one list, as the tests compare them (moved out of
``sondalog.web.blocks``, where nothing else asked for them: the dashboard reads them a
channel at a time, :func:`sondalog.web.blocks.by_channel`)."""

from __future__ import annotations

from sondalog.web import blocks
from sondalog.web.db import Db

Row = tuple[int, int, float | None, int, float | None, int]


def rows(db: Db, logger: str, p: blocks.Plan, *, use_blocks: bool | None = None) -> list[Row]:
    """``(bucket, channel, vmin, tmin, vmax, tmax)`` of the buckets of ``p`` by channel and
    bucket: :func:`~sondalog.web.blocks.by_channel` as one list."""
    per = {ch: list(got) for ch, got in blocks.by_channel(db, logger, p, use_blocks=use_blocks)}
    return [(k, ch, a, b, c, d) for ch in sorted(per) for _, k, a, b, c, d in per[ch]]
