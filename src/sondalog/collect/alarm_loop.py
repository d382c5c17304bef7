"""The collector's alarms (issue 21): the pure core of :mod:`sondalog.collect.alarms` fed by
the runner, its store in the collector's SQLite file (or on the ``[postgres]`` server with
``alarms = true``: :func:`alarm_store`), and a task that notifies.

What the runner feeds (docs/alarms.md "What the collector feeds"):

- every delivered reading (:meth:`AlarmLoop.readings`), before its cursor is committed;
  readings of a channel of type 1 (supply voltage, §6.5.6) are the logger's ``supply`` too,
  and the GSM signal and credit a batch brings (channel types 12 and 11, or a message
  source's ``signal``/``credit`` channels) its ``signal``/``credit``;
- every contact, good or failed (:meth:`AlarmLoop.contact`): no contact, a source refusing;
  after a good one the logger's record fill (``record status``), its clock offset and the
  gaps this contact's download noticed (the ``gap`` events it wrote);
- the sinks (:meth:`AlarmLoop.sink`): down or up, and how many batches wait in the buffer.

Every observation's transitions, their history rows, their outbox rows and the alarms'
states are written in one transaction of the alarm store, before the runner commits the
readings' cursor: a crash in between reads the rows again and finds the transitions taken.
:meth:`AlarmLoop.run` is the timer and the postman: it applies acknowledgements asked for
by people (the dashboard, ``sondalog alarms ack``), raises no-contact and sink timers,
adds repeats, then claims due outbox rows and hands each to its destination's sender.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import re
import socket
import time
from collections.abc import Callable, Iterable, Sequence
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from sondalog.collect.alarms import (
    LEASE,
    Alarms,
    AlarmStore,
    Condition,
    Contact,
    Health,
    Message,
    Policy,
    Transition,
)
from sondalog.collect.alarms.events import reading_time
from sondalog.collect.alarms.senders import DeliveryError, Sender, sender_for
from sondalog.collect.config import MESSAGE_KINDS, CollectorConfig, SourceConfig
from sondalog.collect.config_history import drift as config_drift
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore

if TYPE_CHECKING:
    from sondalog.collect.alarms.store_pg import PostgresAlarmStore

    #: Either alarm store: the same methods.
    Store = AlarmStore | PostgresAlarmStore

log = logging.getLogger(__name__)
#: Seconds between looks for acknowledgements asked for by another process.
ACK_POLL = 1.0
#: Seconds a clean stop waits for a notification already being sent (docs/alarms.md).
DRAIN = 10.0
#: Channel type of a supply voltage (§6.5.6).
SUPPLY_TYPE = 1
_GAP_ROWS = re.compile(r"about (\d+) rows")


def alarm_store(config: CollectorConfig) -> Store:
    """Where the alarm tables of ``config`` are: on the ``[postgres]`` server when its table
    says ``alarms = true`` (shared by every collector using it), otherwise in the
    collector's SQLite store file. Not opened yet."""
    postgres = config.sinks.get("postgres")
    if postgres is not None and getattr(postgres, "alarms", False):
        from sondalog.collect.alarms.store_pg import PostgresAlarmStore

        return PostgresAlarmStore(postgres.dsn, postgres.connect_timeout)
    return AlarmStore(config.store)


def text_time(text: object) -> float | None:
    """An ISO 8601 text of the store (``last_contact``) as seconds since the epoch."""
    if not text:
        return None
    try:
        return datetime.fromisoformat(str(text)).timestamp()
    except ValueError:
        return None


def fill_ratio(record_fill: object) -> float | None:
    """``record status`` = ``chars,fraction,STATE`` -> the fraction (0..1)."""
    parts = str(record_fill or "").split(",")
    try:
        return float(parts[1]) if len(parts) > 1 else None
    except ValueError:
        return None


class AlarmLoop:
    """The alarms of ``config`` on its store; ``clock``: the wall clock (seconds)."""

    def __init__(self, config: CollectorConfig, clock: Callable[[], float] = time.time) -> None:
        self.config = config
        self.plan = config.alarms
        self.clock = clock
        self.store: Store = alarm_store(config)
        self.alarms = Alarms(self.plan)
        self.policy = Policy(self.plan, self.store, zone=_local_zone())
        #: Who claims outbox rows: stable across restarts of this collector, so a restart
        #: takes back the rows it held when it was killed instead of waiting for the lease.
        self.owner = f"{socket.gethostname()}:{config.path.resolve()}"
        self.senders: dict[str, Sender] = {}
        self.sqlite: SqliteStore | None = None
        self._sources: list[SourceConfig] = []
        self._stale = False
        self._supply: dict[str, set[int]] = {}
        self._gap_mark: dict[str, int] = {}
        #: Message sources and whether their contact brought rows: a good poll of a mailbox
        #: is not its logger heard from.
        self._messages = {s.name for s in config.sources if s.kind in MESSAGE_KINDS}
        self._heard: dict[str, bool] = {}
        #: What the health rules measure: a batch's readings are looked at for the supply,
        #: its state for the signal and credit, only if a rule wants them.
        measures = {r.measure for r in self.plan.of_kind("health")}
        self._watch_supply = "supply" in measures
        self._watch_gsm = bool(measures & {"signal", "credit"})
        self._wake: asyncio.Event | None = None
        self.sent = 0

    # -- opening --------------------------------------------------------------------------

    def open(self, sqlite: SqliteStore, sources: Iterable[SourceConfig]) -> None:
        """Open the alarm tables (in the collector's store file), restore the alarms' states,
        and watch every source for no contact from its last stored contact."""
        self.sqlite = sqlite
        self._sources = list(sources)
        self.store.open()
        self.store.release(self.owner)
        self._restore()

    def hold(self, sources: set[str]) -> None:
        """Collectors that share their sources (docs/scaling.md): only the ``sources`` this
        one holds now are watched for no contact, and the states are read again from the
        store (the collector that held a source before changed them)."""
        self._sources = [s for s in self.config.sources if s.name in sources]
        self._stale = True

    def _restore(self) -> None:
        """The alarms as the store has them (at the start, and after a failed write: the
        transitions it lost are computed again from the readings read again)."""
        assert self.sqlite is not None
        sqlite = self.sqlite
        self.alarms = Alarms(self.plan, self.store.load_states())
        self._stale = False
        now = self.clock()
        for source in self._sources:
            row = sqlite.source(source.name) or {}
            self.alarms.watch_source(
                source.name,
                source.interval,
                now=now,
                last_contact=text_time(row.get("last_contact")),
                logger=row.get("logger"),
            )
        self._commit([], now)

    async def close(self) -> None:
        for sender in self.senders.values():
            with contextlib.suppress(Exception):
                await sender.close()
        self.senders.clear()
        self.store.close()

    # -- observations ---------------------------------------------------------------------

    def _commit(
        self, transitions: Sequence[Transition], now: float, *, repeats: bool = False
    ) -> None:
        """Record ``transitions``, queue their notifications (and, on the timer's turn, the
        repeats due: they depend on the time, not on readings, and finding them looks at
        every alarm) and save the states, in one transaction. If it fails (the PostgreSQL
        server went away) the memory no longer matches the store: it is read again first
        on the next observation."""
        try:
            with self.store.transaction():
                added = []
                if transitions:  # most chunks change no alarm's state
                    self.store.record(transitions)
                    added = self.policy.notify(transitions, now)
                if repeats:
                    added += self.policy.repeats(self.alarms.active(), now)
                self.store.save_changes(self.alarms.changes())
        except BaseException:
            self._stale = True
            raise
        for t in transitions:
            log.warning("alarm %s %s: %s", t.what, t.alarm, t.text)
        if (transitions or added) and self._wake is not None:
            self._wake.set()

    def readings(self, source: str, batch: Sequence[Reading], **state: Any) -> None:
        """A delivered batch (``state``: what the source's row gets with it: signal, credit).

        The rules see the readings through :meth:`Alarms.ingest` (the fast path, proven the
        same as one :class:`Sample` a reading); only supply channels and the batch's last
        reading are made samples, for the health rules."""
        if batch:  # a logger was heard from (a skipped message brings none)
            self._heard[source] = True
        last = next((r for r in reversed(batch) if r.value is not None), None)
        if last is None:
            return
        self._fresh()
        out = self.alarms.ingest(source, batch)  # it skips readings without a value
        if self._watch_supply:
            out += self._supply_health(source, batch)
        signal, credit = state.get("signal"), state.get("credit")
        if self._watch_gsm and (signal is not None or credit is not None):
            out += self.alarms.health(
                Health(source, reading_time(last), last.logger, signal=signal, credit=credit)
            )
        self._commit(out, self.clock())

    def _supply_health(self, source: str, batch: Sequence[Reading]) -> list[Transition]:
        """The readings of supply channels as the loggers' ``supply``."""
        out: list[Transition] = []
        logger: str | None = None
        supply: set[int] = set()
        for r in batch:
            if r.logger != logger:  # a batch is mostly one logger's
                logger = r.logger
                supply = self._supply_channels(logger)
            if r.value is not None and r.channel in supply:
                out += self.alarms.health(Health(source, reading_time(r), r.logger, supply=r.value))
        return out

    def _supply_channels(self, logger: str) -> set[int]:
        found = self._supply.get(logger)
        if found is None and self.sqlite is not None:
            rows = self.sqlite.db.execute(
                "SELECT channel FROM channels WHERE logger = ? AND type = ?",
                (logger, SUPPLY_TYPE),
            )
            found = self._supply[logger] = {int(r[0]) for r in rows}
        return found or set()

    def contact_started(self, source: str) -> None:
        """Remember where the events table stands (the gaps this contact writes count)."""
        self._heard[source] = False
        if self.sqlite is not None:
            row = self.sqlite.db.execute("SELECT coalesce(max(id), 0) FROM events").fetchone()
            self._gap_mark[source] = int(row[0])

    def _fresh(self) -> None:
        if self._stale and self.sqlite is not None:
            self._restore()

    def contact(self, source: str, ok: bool, error: str | None = None) -> None:
        """A contact of ``source`` ended, well or not (a store that fails is logged: the
        source goes on)."""
        try:
            self._fresh()
            now = self.clock()
            heard = source not in self._messages or self._heard.get(source, False)
            out = self.alarms.contact(Contact(source, ok, now, error, heard))
            if ok:
                out += self._contact_health(source, now)
            self._commit(out, now)
        except Exception as exc:
            log.warning("alarms: %s", exc)

    def _contact_health(self, source: str, now: float) -> list[Transition]:
        if self.sqlite is None:
            return []
        row = self.sqlite.source(source) or {}
        logger = row.get("logger")
        if logger is not None:
            self._supply.pop(str(logger), None)  # the channels may have changed
        gaps: float | None = None
        mark = self._gap_mark.pop(source, None)
        if mark is not None:
            texts = self.sqlite.db.execute(
                "SELECT text FROM events WHERE id > ? AND source = ? AND kind = 'gap'",
                (mark, source),
            ).fetchall()
            gaps = 0.0
            for (text,) in texts:
                found = _GAP_ROWS.search(str(text))
                gaps += float(found.group(1)) if found else 1.0
        offset = row.get("offset_s")
        health = Health(
            source,
            now,
            None if logger is None else str(logger),
            memory=fill_ratio(row.get("record_fill")),
            clock=None if offset is None else float(offset),
            gaps=gaps if row.get("kind") == "logger" else None,
            drift=config_drift(self.sqlite.db, source),
        )
        return self.alarms.health(health)

    def sink(self, name: str, up: bool, waiting: int) -> None:
        """A sink's state after a delivery or a replay: up or down, ``waiting`` batches."""
        try:
            self._fresh()
            now = self.clock()
            out = self.alarms.condition(Condition("sink", name, 0.0 if up else 1.0, now))
            out += self.alarms.condition(Condition("buffer", name, float(waiting), now))
            self._commit(out, now)
        except Exception as exc:  # the sink's delivery goes on
            log.warning("alarms: %s", exc)

    # -- the timer and the postman --------------------------------------------------------

    def turn(self, now: float) -> None:
        """Acknowledgements asked for, timers, repeats: one transaction."""
        self._fresh()
        with self.store.transaction():
            out: list[Transition] = []
            for alarm, by, requested in self.store.take_ack_requests(now):
                acked = self.alarms.acknowledge(alarm, requested, by)
                if acked is not None:
                    out.append(acked)
            out += self.alarms.advance(now)
            self._commit(out, now, repeats=True)

    def next_wake(self, now: float) -> float:
        times = [
            self.alarms.next_deadline(),
            self.policy.next_repeat(self.alarms.active(), now),
            self.store.next_try(),
        ]
        return min([now + ACK_POLL, *(t for t in times if t is not None)])

    async def deliver_due(self, now: float) -> int:
        """Claim the due outbox rows and send them (destinations side by side); how many
        were delivered."""
        by_dest: dict[str, list[Message]] = {}
        for message in self.store.claim(now, self.owner, LEASE):
            by_dest.setdefault(message.destination, []).append(message)
        done = await asyncio.gather(*(self._send_all(ms) for ms in by_dest.values()))
        return sum(done)

    async def _send_all(self, messages: list[Message]) -> int:
        done = 0
        for message in messages:
            notify = self.plan.notify.get(message.destination)
            try:
                if notify is None:
                    raise DeliveryError(f"no [[notify]] named {message.destination!r} any more")
                sender = self.senders.get(notify.name)
                if sender is None:
                    sender = self.senders[notify.name] = sender_for(notify)
                await self._sending(sender, message)
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # DeliveryError, or a sender's bug: retried, logged
                error = str(exc) if isinstance(exc, DeliveryError) else repr(exc)
                log.warning("notification %s not delivered: %s", message.key, error)
                self.policy.failed(message, self.clock(), error)
                continue
            self._delivered(message)
            done += 1
        return done

    def _delivered(self, message: Message) -> None:
        self.store.delivered(message.key, self.clock())
        self.sent += 1

    async def _sending(self, sender: Sender, message: Message) -> None:
        """``sender.send(message)``; cancelled (a clean stop) while the message is on its
        way, it waits up to :data:`DRAIN` seconds for the destination's answer and records
        the delivery before it gives way: a restart does not send it again. (The e-mail's
        SMTP talk runs in a thread a cancel cannot stop: it would reach the server all the
        same, and go again after the restart.) Past :data:`DRAIN` it stays pending."""
        send = asyncio.ensure_future(sender.send(message))
        try:
            await asyncio.shield(send)
        except asyncio.CancelledError:
            try:
                done, _ = await asyncio.wait({send}, timeout=DRAIN)
            except asyncio.CancelledError:  # cancelled again: no more waiting
                done = set()
            if not done:
                send.cancel()
            elif not send.cancelled() and send.exception() is None:
                with contextlib.suppress(Exception):
                    self._delivered(message)
                    log.info("notification %s delivered while stopping", message.key)
            raise

    async def run(self) -> None:
        """Until cancelled: a turn, the deliveries, then sleep until the next deadline or
        until an observation adds something."""
        self._wake = wake = asyncio.Event()
        while True:
            wake.clear()
            now = self.clock()
            try:
                self.turn(now)
                await self.deliver_due(now)
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # a locked store, a bug: try again, never stop
                log.warning("alarms: %s", exc)
            delay = max(0.0, self.next_wake(self.clock()) - self.clock())
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(wake.wait(), timeout=max(delay, 0.05))


def _local_zone() -> Any:
    return datetime.now().astimezone().tzinfo or UTC
