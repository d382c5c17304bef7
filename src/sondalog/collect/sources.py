"""The collector's sources: loggers by URL (incremental download) and HCTMPS1 buses (polled).

A source's :meth:`poll` makes one contact and hands every batch of readings to a
:data:`Deliver` callback with the source's new cursor; the runner stores both in one
transaction (:meth:`~sondalog.collect.store_sqlite.SqliteStore.commit_chunk`) after passing the
batch to the other sinks. A logger source resumes after the cursor kept in the store's
``sources`` table (one per logger), so a collector killed at any moment goes on where the
store stands.
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable
from datetime import datetime
from typing import Any

from sondalog.client import Ala1Client, BusMaster
from sondalog.client.download import ClockReading, Download
from sondalog.client.endpoints import Endpoint, parse_url
from sondalog.client.records import UTC
from sondalog.client.visit import Known, Visit, keep, visit
from sondalog.collect.config import MESSAGE_KINDS, SourceConfig
from sondalog.collect.config_watch import ConfigWatch
from sondalog.collect.delivery import GSM_TYPES, Deliver
from sondalog.collect.delivery import Source as Source
from sondalog.collect.keep_open import KeptConnections, close_quietly
from sondalog.collect.message_sources import MailboxSource, NetworkSource
from sondalog.collect.model import Reading
from sondalog.collect.readings import rows_to_readings
from sondalog.collect.store_sqlite import SqliteStore, now_text

log = logging.getLogger(__name__)


class LoggerSource:
    """An ALA1 logger: incremental download after the store's cursor (§6.6.1.1).

    A contact is one pipelined write of two lines in the usual case
    (:func:`~sondalog.client.visit.visit`: the identification, ``read record status``, the
    channel types and formats and the first chunk, chained); an identification that answers
    as at the last contact is not parsed again. Its store writes (each chunk with the
    source's state, the runner's end of contact, ``contacting`` for a contact longer than a
    second) wait for the store's write-behind flush: one transaction for the contacts of a
    second. The ``channels`` rows are written when they change (and at the first contact of
    this process).
    """

    kind = "logger"

    def __init__(
        self, config: SourceConfig, store: SqliteStore, kept: KeptConnections | None = None
    ) -> None:
        self.config = config
        self.store = store
        #: Where a ``keep_open`` source's connection waits between contacts (None: closed
        #: after each contact).
        self.kept = kept if config.keep_open else None
        self._hint: str | None = None  # the last idle_hint logged
        self.watch = ConfigWatch(config, store)  # its configuration (issue 22)
        self._count: int | None = None  # the channel count of the last contact
        self._channels: int | None = None  # the hash of what set_channels last wrote
        self._endpoint: Endpoint | None = None
        self._known: Known | None = None  # the last contact's identification
        self._gsm: dict[int, str] = {}  # channel -> the sources column of its GSM type

    async def poll(self, deliver: Deliver) -> str:
        cfg, kept = self.config, self.kept
        if self._endpoint is None:
            self._endpoint = parse_url(cfg.url)
        if kept is not None and (reused := kept.take(cfg.name)) is not None:
            try:
                summary = await self._contact(reused, deliver)
            except Exception as exc:  # closed or reset since, or dead: once more, afresh
                await close_quietly(reused)
                log.info("source %s: kept connection failed (%s); reconnecting", cfg.name, exc)
            except BaseException:
                await close_quietly(reused)
                raise
            else:
                kept.keep(cfg.name, reused)
                return summary
        client = await Ala1Client.connect(self._endpoint, timeout=cfg.timeout)
        if kept is not None:
            kept.opened += 1
        try:
            summary = await self._contact(client, deliver)
        except BaseException:
            await close_quietly(client)
            raise
        if kept is None or not kept.keep(cfg.name, client):
            await client.close()
        return summary

    async def _contact(self, client: Ala1Client, deliver: Deliver) -> str:
        """One contact on ``client``'s connection (left open: :meth:`poll` closes or keeps
        it); resumes after the store's cursor, so a repeated contact reads no row twice."""
        cfg, store = self.config, self.store
        state: dict[str, Any] = {}
        try:
            known = store.source(cfg.name) or {}
            download = Download(client, after=known.get("cursor"), zone=cfg.zone)
            visited = await visit(download, self._count, self._known)
            info = visited.info
            self._count = len(info.channels)
            if self._known is None or visited.key != self._known[0]:
                self._channels_read(visited)
                self._known = keep(visited)
            gsm = self._gsm
            state = {
                "logger": info.snumber,
                "last_contact": now_text(),
                "offset_s": info.clock.offset,
                "record_fill": visited.status,
            }
            if known.get("logger") not in (None, info.snumber):
                text = (
                    f"another logger answers at {cfg.url}: {info.snumber} instead of "
                    f"{known['logger']}; reading its record from the oldest row"
                )
                log.warning("%s: %s", cfg.name, text)
                store.event(cfg.name, "logger", text)
                download.after = None
                store.set_state(cfg.name, cursor=None)
            record_fill = state["record_fill"]
            configured = await self.watch.check(client)
            rows = readings = 0
            first = last = None
            async for chunk in download.chunks():
                if chunk.gap is not None:
                    log.warning("%s: %s", cfg.name, chunk.gap.describe())
                    store.event(cfg.name, "gap", chunk.gap.describe())
                batch = rows_to_readings(chunk.rows, info.snumber, info.channels, cfg.zone)
                latest = {gsm[r.channel]: r.value for r in batch if r.channel in gsm}
                # the contact's state goes with the first chunk, in its transaction
                await deliver(cfg.name, batch, chunk.cursor, **{**state, **latest})
                state = {}
                rows += len(chunk.rows)
                readings += len(batch)
                first = first or (chunk.rows[0].key if chunk.rows else None)
                last = chunk.cursor or last
        finally:
            if state:  # no chunk took it (nothing new, or the download failed)
                store.set_state(cfg.name, **state)
        span = f" ({first} .. {last})" if rows else ""
        summary = (
            f"logger {info.snumber}: {rows} new rows, {readings} readings{span}; "
            f"{info.clock.describe()}" + (f"; {configured}" if configured else "")
        )
        hint = idle_hint(rows, record_fill, info.clock)
        if hint is not None and hint != self._hint:  # said once, not at every contact
            log.warning("source %s: %s", cfg.name, hint)
        self._hint = hint
        return summary if hint is None else f"{summary}; {hint}"

    def _channels_read(self, visited: Visit) -> None:
        """The ``channels`` rows of a contact whose identification differs from the last
        one's (or was read step by step): written when they changed."""
        info = visited.info
        types, formats = _channel_types(visited.kinds, len(info.channels))
        rows_ = [(n, c.name, c.unit, types.get(n)) for n, c in sorted(info.channels.items())]
        written = hash((info.snumber, tuple(rows_), tuple(sorted(formats.items()))))
        if self._channels != written:  # a hash: 10,000 sources keep no copies
            self.store.set_channels(info.snumber, rows_, formats)
            self._channels = written
        self._gsm = {n: GSM_TYPES[t] for n, t in types.items() if t in GSM_TYPES}


#: A logger clock this far from the host's was never set (a fresh logger reads 2000-01-01).
UNSET_CLOCK = 30 * 86400.0


def idle_hint(rows: int, record_fill: str | None, clock: ClockReading) -> str | None:
    """What the logger shows when a contact brings nothing (or rows on an unset clock): its
    clock not set (§6.2) and an empty record, as a fresh or reset logger has (§6.6.5
    ``read record status`` ``0,...``: no channel has a sampling period, §6.5.14)."""
    says = []
    if abs(clock.offset) >= UNSET_CLOCK:
        says.append(
            f"its clock reads {clock.logger_time.isoformat()}, not set? (write date YYYYMMDDhhmmss)"
        )
    if not rows and record_fill is not None and record_fill.split(",")[0].strip() == "0":
        says.append(
            "nothing to collect: its record is empty (a channel records only with a sampling "
            "period: write channel N sampling period hhmmss)"
        )
    return "; ".join(says) or None


def _channel_types(lines: tuple[str, ...], count: int) -> tuple[dict[int, int], dict[int, str]]:
    """The answers of ``read channel type`` and ``read channel format``: channel number ->
    type, and -> value format (§6.5.7); {} for an answer that is not that."""
    fields = [line.split(",") for line in lines[:2]]
    types: dict[int, int] = {}
    if fields and len(fields[0]) == count and all(f.strip().isdigit() for f in fields[0]):
        types = {n: int(f) for n, f in enumerate(fields[0], start=1)}
    formats: dict[int, str] = {}
    if len(fields) == 2 and len(fields[1]) == count:
        formats = {n: f.strip() for n, f in enumerate(fields[1], start=1) if _FORMAT.fullmatch(f)}
    return types, formats


#: A value format as the logger answers it: ``w.p`` (§4.3.5, §6.5.7).
_FORMAT = re.compile(r"\s*\d\.\d\s*")


class BusSource:
    """HCTMPS1 modules on a bus: each contact reads every module's value (``PV``)."""

    kind = "bus"

    def __init__(
        self, config: SourceConfig, store: SqliteStore, clock: Callable[[], float] = time.time
    ) -> None:
        self.config = config
        self.store = store
        self.clock = clock

    async def poll(self, deliver: Deliver) -> str:
        cfg = self.config
        master = await BusMaster.open(cfg.url)
        try:
            modules = list(cfg.modules) or list(await master.scan())
            batch: list[Reading] = []
            failed: list[str] = []
            for module in modules:
                try:
                    value = await master.pv(module)
                except Exception as exc:  # one silent module must not hide the others
                    failed.append(f"{module} ({exc})")
                    continue
                now = self.clock()
                local = datetime.fromtimestamp(now, cfg.zone).replace(tzinfo=None, microsecond=0)
                utc = datetime.fromtimestamp(now, UTC).replace(microsecond=0)
                batch.append(
                    Reading(
                        f"bus:{module}",
                        1,
                        local,
                        0,
                        1,
                        value,
                        None,
                        module,
                        cfg.units.get(module),
                        utc if cfg.zone is not None else None,
                    )
                )
        finally:
            await master.close()
        if modules and not batch:
            raise OSError(f"no module answered: {', '.join(failed)}")
        await deliver(cfg.name, batch, None, last_contact=now_text(), logger="bus")
        text = f"bus: {len(batch)} of {len(modules)} modules read"
        return text + (f"; no answer from {', '.join(failed)}" if failed else "")


def make_source(
    config: SourceConfig, store: SqliteStore, kept: KeptConnections | None = None
) -> Source:
    """The source of ``config``; a ``keep_open`` logger keeps its connection in ``kept``."""
    if config.kind == "bus":
        return BusSource(config, store)
    if config.kind in MESSAGE_KINDS:
        return (
            MailboxSource(config, store)
            if config.kind == "mailbox"
            else NetworkSource(config, store)
        )
    return LoggerSource(config, store, kept)
