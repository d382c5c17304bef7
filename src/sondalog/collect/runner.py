"""The collector's loop: one asyncio task per source, batches to every sink, retry with backoff.

- Each source is contacted every ``interval`` seconds (start to start, on a grid of loop time:
  the sources due within a step start together, :mod:`sondalog.collect.ticks`; the first
  contacts are spread over 5 s, or over as many seconds as :data:`START_RATE` contacts a
  second need, at most the shortest interval: ten thousand sources every minute start at an
  even 167 a second instead of all within 5 s, which held thousands of connections open at
  once).
- A failed contact (unreachable, no answer, garbage) sets the source's state to ``offline``
  with the error in the ``sources`` table, the log and the events table, and is retried after
  ``retry`` seconds, doubling up to ``retry_max`` (then every ``interval`` again once it works).
- Every batch goes to each configured sink through the on-disk buffer
  (:mod:`sondalog.collect.buffer`): a sink that is down (:class:`SinkUnavailable`) keeps its
  batches queued, and a task replays them every few seconds. Then the readings and the
  source's cursor are committed to the SQLite store in one transaction. Sinks insert
  idempotently, so a batch replayed after a crash is stored once.
- A ``keep_open`` source's connection waits between its contacts in :attr:`Collector.kept`
  (:mod:`sondalog.collect.keep_open`); it is closed when its source stops (the collector
  stops, the cluster hands the source on, :meth:`Collector.reload` removes it).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import gc
import logging
import time
from typing import Any

from sondalog.collect.alarm_loop import AlarmLoop
from sondalog.collect.buffer import DiskBuffer, deliver, drain
from sondalog.collect.config import CollectorConfig
from sondalog.collect.keep_open import KeptConnections
from sondalog.collect.model import Announcing, Reading, Sink, SinkUnavailable
from sondalog.collect.share import Share, share_of
from sondalog.collect.sinks import build_sinks
from sondalog.collect.sources import Source, make_source
from sondalog.collect.store_sqlite import SqliteStore, now_text
from sondalog.collect.ticks import Ticks, grid_instant, next_due, step_for

log = logging.getLogger(__name__)
#: Seconds between replays of the buffered batches of sinks that were down.
REPLAY_PERIOD = 5.0
#: The first contacts are spread over at least this many seconds (at most the shortest
#: interval)...
SPREAD = 5.0
#: ... and over as many as it takes to start at most this many contacts a second.
START_RATE = 100.0


def describe(exc: BaseException) -> str:
    """``ConnectionRefusedError: [Errno 111] ...``: the error's type and message."""
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


#: Seconds the store's writes of contacts wait to be committed together (one transaction for
#: every contact of that time instead of three a contact; SqliteStore.write_behind).
WRITE_BEHIND = 1.0

#: A contact still running after this many seconds is marked ``contacting`` in the store.
CONTACTING_AFTER = 1.0

#: The cyclic collector's threshold of its youngest generation in a running collector.
GC_YOUNG = 10_000

#: How long a clean stop spends delivering the disk buffer to sinks that are up (s).
FINAL_REPLAY = 5.0


def settle_gc() -> None:
    """The cyclic garbage collector as a running collector process wants it (issue 24).

    What exists now (every source, its configuration, the modules) lives as long as the
    process: frozen, out of the way of the full passes that came with the contacts' garbage
    over ten thousand sources' objects. A contact's or a batch's objects die within
    milliseconds: the youngest generation is looked at after ``GC_YOUNG`` new objects instead
    of 700, by when most are gone (never traversed, never promoted to be traversed again).
    ``benchmarks/bench_collect.py`` calls it too, so that a sink is measured in the process
    a user runs it in.
    """
    gc.freeze()
    young, *older = gc.get_threshold()
    gc.set_threshold(max(GC_YOUNG, young), *older)


class Collector:
    """Runs the sources of ``config`` until :meth:`run`'s ``stop`` event is set."""

    def __init__(self, config: CollectorConfig) -> None:
        self.config = config
        self.store = SqliteStore(config.store, readings=config.keep_readings)
        self.store.write_behind = WRITE_BEHIND
        self.sinks: list[Sink] = []
        self._opened: set[str] = set()
        self.buffer: DiskBuffer | None = None
        self.sources: list[Source] = []
        #: The ``keep_open`` sources' connections between contacts.
        self.kept = KeptConnections()
        #: The running sources' tasks by name (:meth:`run`, :meth:`reload`).
        self._tasks: dict[str, asyncio.Task[None]] = {}
        self._once = False
        self._changed: asyncio.Future[None] | None = None  # set when reload changes them
        #: Tasks of sources a reload stopped, until they end (the stop waits for them too).
        self._retired: set[asyncio.Task[None]] = set()
        #: A contact marked ``contacting``: the state before, put back if it is cancelled.
        self._was: dict[str, object] = {}
        self.contacts = 0
        #: Sources whose last contact failed.
        self.failing: set[str] = set()
        #: The alarms (docs/alarms.md), when the file has ``[[alarm]]`` rules.
        self.alarms: AlarmLoop | None = AlarmLoop(config) if config.alarms.rules else None
        #: ``[cluster]``: the sources this collector holds are polled (docs/scaling.md).
        self.share: Share | None = None
        #: The grid the contacts start on (:mod:`sondalog.collect.ticks`).
        self.ticks = Ticks()

    def open(self) -> None:
        """Build the sinks (their tables were checked when the file was loaded) and open the
        store; raises ``StoreError``."""
        self.sinks = build_sinks(self.config.sinks)
        self.store.open_sync()
        if self.sinks:
            self.buffer = DiskBuffer(self.config.buffer)
        for source_config in self.config.sources:
            self.store.add_source(source_config.name, source_config.url, source_config.kind)
            self.sources.append(make_source(source_config, self.store, self.kept))
        hold = None if self.alarms is None else self.alarms.hold
        self.share = share_of(self.config, self.store, self.sources, self._confirmed, hold)
        if self.alarms is not None:
            self.alarms.open(self.store, () if self.share else self.config.sources)

    async def run(self, stop: asyncio.Event, *, once: bool = False) -> None:
        """Contact every source until ``stop`` is set (``once``: one contact each, then return)."""
        if not self.store.is_open:
            self.open()
        for sink in self.sinks:
            if once and isinstance(sink, Announcing):
                sink.stay_online = True  # cron runs: online between them (docs/decisions.md)
            await self._open_sink(sink)
        count = len(self.sources)
        shortest = min([*(s.config.interval for s in self.sources), 1e9])
        spread = 0.0 if once else min(shortest, max(SPREAD, count / START_RATE))
        self._once = once
        if self.share is None:
            for i, source in enumerate(self.sources):
                self._start(source, spread * i / count)
        cluster = []
        if self.share is not None:  # the sources it holds, started and stopped by it
            cluster.append(asyncio.create_task(self.share.run(self._loop, once), name="cluster"))
        if not once:
            settle_gc()
        replay = asyncio.create_task(self._replay(), name="sink replay")
        background = [replay]
        if self.alarms is not None:
            background.append(asyncio.create_task(self.alarms.run(), name="alarms"))
        try:
            if once:
                await asyncio.gather(*self._tasks.values(), *cluster)
                await self._replay_once()
                if self.alarms is not None:  # one turn: timers, and what is due now
                    self.alarms.turn(time.time())
                    await self.alarms.deliver_due(time.time())
            else:
                await self._until(stop, cluster)
        finally:
            tasks = [*self._tasks.values(), *self._retired, *cluster, *background]
            self._tasks.clear()
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
            if not once:  # a clean stop hands a sink that is up what waits for it, briefly
                with contextlib.suppress(Exception):
                    await asyncio.wait_for(self._replay_once(), FINAL_REPLAY)
            await self.close()

    async def close(self) -> None:
        for sink in self.sinks:
            if sink.name in self._opened:
                with contextlib.suppress(Exception):
                    await sink.close()
        self._opened.clear()
        if self.alarms is not None:
            await self.alarms.close()
        if self.buffer is not None:
            self.buffer.close()
            self.buffer = None
        self.store.close_sync()
        self.kept.close()

    def _start(self, source: Source, delay: float) -> None:
        name = source.config.name
        self._tasks[name] = asyncio.create_task(
            self._loop(source, delay, self._once), name=f"source {name}"
        )

    async def _until(self, stop: asyncio.Event, cluster: list[asyncio.Task[None]]) -> None:
        """Until ``stop`` is set, or a source's task (or the cluster's) ends: only by a bug
        (it stops the collector, as it always did); a task :meth:`reload` stopped is not."""
        stopper = asyncio.create_task(stop.wait())
        try:
            while not stopper.done():
                self._changed = asyncio.get_running_loop().create_future()
                watched: list[asyncio.Future[Any]] = [
                    stopper,
                    self._changed,
                    *self._tasks.values(),
                    *cluster,
                ]
                done, _ = await asyncio.wait(watched, return_when=asyncio.FIRST_COMPLETED)
                running = {*self._tasks.values(), *cluster}
                if any(task in running for task in done):
                    return
        finally:
            stopper.cancel()
            self._changed = None

    async def reload(self, config: CollectorConfig) -> tuple[int, int, int]:
        """Take the sources of ``config`` (the file read again) while running: a source no
        longer in it stops and its kept connection is closed, a new one starts, a changed
        one starts again with its new settings. Everything else (store, sinks, web, alarms,
        cluster) stays as it was loaded (the alarms stop watching a removed source); a
        collector sharing its sources (``[cluster]``) takes no new list (``ValueError``).
        Returns how many sources were added, removed and changed."""
        if self.share is not None or config.cluster is not None:
            raise ValueError("a collector of a [cluster] takes a new source list at a restart")
        old = {s.config.name: s for s in self.sources}
        new = {c.name: c for c in config.sources}
        stopped = [n for n, s in old.items() if new.get(n) != s.config]
        starting = [c for c in config.sources if c.name not in old or c.name in stopped]
        for source_config in starting:  # the store first: if it fails, nothing has changed
            self.store.add_source(source_config.name, source_config.url, source_config.kind)
        tasks = [t for n in stopped if (t := self._tasks.pop(n, None)) is not None]
        for task in tasks:  # its task's end closes its kept connection
            task.cancel()
            self._retired.add(task)
            task.add_done_callback(self._retired.discard)
        if tasks:  # (a contact under way ends first: at most its timeout; a cancel of the
            await asyncio.wait(tasks)  # reload itself is not swallowed here)
        self.config = dataclasses.replace(self.config, sources=config.sources)
        sources = []
        for source_config in config.sources:
            source = old.get(source_config.name)
            if source is None or source_config.name in stopped:
                source = make_source(source_config, self.store, self.kept)
                if self._changed is not None:  # running (else run starts it)
                    self._start(source, 0.0)
            sources.append(source)
        self.sources = sources
        if self.alarms is not None:  # a removed source is watched no more (a new one is not
            self.alarms.hold(set(new))  # watched for no contact before a restart)
        if self._changed is not None and not self._changed.done():
            self._changed.set_result(None)
        removed = len(old.keys() - new.keys())
        return len(new.keys() - old.keys()), removed, len(stopped) - removed

    async def _open_sink(self, sink: Sink) -> bool:
        try:
            await sink.open()
        except (SinkUnavailable, OSError) as exc:
            log.warning(
                "sink %s is down (%s): batches wait in %s", sink.name, exc, self.config.buffer
            )
            self._sink_state(sink, up=False)
            return False
        self._opened.add(sink.name)
        return True

    async def deliver(
        self, source: str, batch: list[Reading], cursor: str | None, **state: Any
    ) -> None:
        """Hand ``batch`` to every sink (through the buffer), then commit it with the cursor."""
        if batch and self.buffer is not None:
            for sink in self.sinks:
                if sink.name in self._opened:
                    up = await deliver(self.buffer, sink, batch)
                else:
                    self.buffer.append(sink.name, batch)
                    up = False
                self._sink_state(sink, up)
        if self.alarms is not None:  # alarms and their notifications before the cursor
            self.alarms.readings(source, batch, **state)
        self.store.commit_chunk(source, batch, cursor, **state)

    def _confirmed(self) -> bool:
        """Every batch delivered so far is on the PostgreSQL server (none waits for it)."""
        return self.buffer is None or self.buffer.count("postgres") == 0

    def _sink_state(self, sink: Sink, up: bool) -> None:
        if self.alarms is not None and self.buffer is not None:
            self.alarms.sink(sink.name, up, self.buffer.count(sink.name))

    def _contacting(self, name: str) -> None:
        self._was[name] = (self.store.source(name) or {}).get("state")
        self.store.set_state(name, state="contacting")

    async def _loop(self, source: Source, delay: float, once: bool) -> None:
        try:
            await self._contacts(source, delay, once)
        finally:  # stopped: its connection is not kept for a contact that will not come
            self.kept.drop(source.config.name)

    async def _contacts(self, source: Source, delay: float, once: bool) -> None:
        cfg = source.config
        loop = asyncio.get_running_loop()
        task = asyncio.current_task()  # its own: asked once, not at every contact
        due = loop.time() + delay  # when this contact is due; it starts on the grid after
        await self.ticks.until(grid_instant(due, step_for(delay)))
        failures = 0
        while True:
            started = loop.time()
            # a contact still running after a second says so (the dashboard's "contacting");
            # a quicker one is never seen at a write-behind flush, and writes nothing
            marking = loop.call_later(CONTACTING_AFTER, self._contacting, cfg.name)
            if self.alarms is not None:
                self.alarms.contact_started(cfg.name)
            try:
                summary = await source.poll(self.deliver)
            except asyncio.CancelledError:
                if cfg.name in self._was:  # stopped mid-contact: not left "contacting"
                    self.store.set_state(cfg.name, state=self._was[cfg.name])
                raise
            except Exception as exc:  # a failing source must never stop the collector
                failures += 1
                wait = min(cfg.retry * 2 ** (failures - 1), cfg.retry_max)
                text = f"{describe(exc)}; retry in {wait:g} s"
                log.warning("source %s offline: %s", cfg.name, text)
                self.store.finish(
                    cfg.name, "error", text, state="offline", last_error=describe(exc)
                )
                self.failing.add(cfg.name)
                if self.alarms is not None:
                    self.alarms.contact(cfg.name, ok=False, error=describe(exc))
            else:
                failures = 0
                self.failing.discard(cfg.name)
                wait = cfg.interval
                log.info("source %s: %s", cfg.name, summary)
                self.store.finish(
                    cfg.name,
                    "download",
                    summary,
                    state="ok",
                    last_error=None,
                    last_contact=now_text(),
                )
                if self.alarms is not None:
                    self.alarms.contact(cfg.name, ok=True)
            finally:  # (nothing above waits: the mark cannot come in between)
                marking.cancel()
                self._was.pop(cfg.name, None)
            self.contacts += 1
            if once:
                return
            if task is not None and task.cancelling() > 0:  # a cancel that a finished wait
                raise asyncio.CancelledError  # swallowed (asyncio.wait_for, 3.11)
            # start to start after a contact that went well, from its end after a failure;
            # on the grid: the sources due within a step start in one wake of the loop
            due = next_due(due, started, loop.time(), wait, failures == 0)
            await self.ticks.until(grid_instant(due, step_for(wait)))

    async def _replay(self) -> None:
        while True:
            await asyncio.sleep(REPLAY_PERIOD)
            await self._replay_once()

    async def _replay_once(self) -> None:
        if self.buffer is None:
            return
        for sink in self.sinks:
            if sink.name not in self._opened and not await self._open_sink(sink):
                continue
            try:
                done = await drain(self.buffer, sink)
            except Exception as exc:  # a sink's bug must not stop the collector
                log.warning("sink %s: replay failed: %s", sink.name, describe(exc))
                continue
            self._sink_state(sink, up=self.buffer.count(sink.name) == 0)
            if done:
                log.info("sink %s: %d buffered batches delivered", sink.name, done)
