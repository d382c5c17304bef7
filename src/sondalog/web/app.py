"""The dashboard's starlette application: pages, JSON API, CSV and live stream.

Routes (see ``docs/dashboard.md``): ``/`` overview, ``/loggers/{logger}`` plot, ``/log``
events; ``/api/loggers``, ``/api/loggers/{logger}``, ``/api/loggers/{logger}/series``,
``/api/loggers/{logger}/readings.csv``, ``/api/loggers/{logger}/stream`` (server-sent
events), ``/api/events``, ``/api/alarms`` and ``POST /api/alarms/{alarm}/ack`` (issue 21,
:mod:`.alarms`: from the collector's alarm store, its SQLite file or the ``[postgres]``
server). Bad parameters get HTTP 400 with the reason, an unknown logger 404,
a store that is not there (yet) 503.
"""

from __future__ import annotations

import asyncio
import csv
import io
import json
import re
import time
from collections.abc import AsyncIterator, Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import (
    HTMLResponse,
    JSONResponse,
    Response,
    StreamingResponse,
)
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from sondalog.collect.alarms.store import AlarmStore, SqlAlarmStore
from sondalog.collect.schema import COLUMNS

from . import alarms, config_log, overview, pages, series, store
from .alarm_api import AlarmHandlers
from .auth import TokenGate
from .db import Readings, query_errors
from .times import BadParameter, parse_time, shift, to_epoch

STATIC = Path(__file__).parent / "static"
T = TypeVar("T")

#: A token: 8 or more characters that survive a URL, a header and a cookie unchanged.
TOKEN_RE = re.compile(r"[A-Za-z0-9._~+/=-]{8,}")


def check_token(token: str | None) -> str | None:
    if token is not None and not TOKEN_RE.fullmatch(token):
        raise ValueError(
            "the web token must be 8 or more characters of letters, digits and ._~+/=-"
        )
    return token


@dataclass
class Settings:
    """What the app serves and how."""

    #: The collector's SQLite file (sources, events, channel types; its readings too unless
    #: ``readings_dsn``); None: a PostgreSQL server alone.
    store: Path | None
    token: str | None = None
    poll_interval: float = 1.0
    max_points: int = 2000
    default_span_s: int = 7 * 86400
    heartbeat_s: float = 15.0
    overview_refresh_s: float = 10.0
    #: Set by :func:`~sondalog.web.serve` when stopping: live streams end.
    stopping: bool = False
    #: The PostgreSQL server the readings are read from (None: the store file's).
    readings_dsn: str | None = None
    #: Where the alarms are (default: the alarm tables of the store file).
    alarms: alarms.AlarmAccess = field(init=False)
    #: Where the readings are (:class:`~.db.Readings`).
    readings: Readings = field(init=False)

    def __post_init__(self) -> None:
        self.readings = Readings(self.store, self.readings_dsn)
        if self.store is not None:
            self.alarms = alarms.AlarmAccess(AlarmStore(self.store))
        else:  # a server alone: the caller names the alarm store (create_app)
            self.alarms = alarms.AlarmAccess(alarms.NoAlarmStore())


def create_app(
    store_path: Path | None,
    *,
    token: str | None = None,
    poll_interval: float = 1.0,
    max_points: int = 2000,
    overview_refresh: float = 10.0,
    alarm_store: SqlAlarmStore | None = None,
    readings_dsn: str | None = None,
) -> Starlette:
    """The dashboard for the store at ``store_path`` (read-only; it may not exist yet).

    ``token``: require it on every request (see :mod:`sondalog.web.auth`);
    ``poll_interval``: seconds between the live stream's looks at the store;
    ``max_points``: the most points per series one plot request sends;
    ``overview_refresh``: seconds between the overview page's refreshes;
    ``alarm_store``: where the collector keeps its alarms (not opened yet: the collector's
    ``alarm_store(config)``, a PostgreSQL store with ``[postgres] alarms = true``); default
    the alarm tables of the store file;
    ``readings_dsn``: read the readings from this PostgreSQL server (the collector's
    ``[postgres]`` sink as its store of record), the rest from ``store_path`` (may be None:
    no sources, events or channel types then).
    """
    if poll_interval <= 0 or overview_refresh <= 0:
        raise ValueError("poll_interval and overview_refresh must be more than 0 seconds")
    if max_points < 10:
        raise ValueError(f"max_points must be 10 or more, got {max_points}")
    if store_path is None and readings_dsn is None:
        raise ValueError("the dashboard needs a store: a file or a PostgreSQL server")
    path = None if store_path is None else Path(store_path)
    settings = Settings(
        path, check_token(token), poll_interval, max_points, readings_dsn=readings_dsn
    )
    settings.overview_refresh_s = overview_refresh
    if alarm_store is not None:
        settings.alarms = alarms.AlarmAccess(alarm_store)
    api = Api(settings)
    routes = [
        Route("/", api.page_overview),
        Route("/log", api.page_log),
        Route("/loggers/{logger}", api.page_plot),
        Route("/api/loggers", api.loggers),
        Route("/api/loggers/{logger}", api.logger),
        Route("/api/loggers/{logger}/series", api.series),
        Route("/api/loggers/{logger}/readings.csv", api.csv),
        Route("/api/loggers/{logger}/stream", api.stream),
        Route("/api/events", api.events),
        Route("/api/alarms", api.alarm_list),
        Route("/api/alarms/{alarm}/ack", api.ack, methods=["POST"]),
        Mount("/static", StaticFiles(directory=STATIC), name="static"),
    ]
    app = Starlette(
        routes=routes,
        middleware=[Middleware(TokenGate, token=lambda: settings.token)],
        exception_handlers={
            BadParameter: _bad_parameter,
            store.StoreUnavailable: _unavailable,
            HTTPException: _http_error,
        },
    )
    app.state.settings = settings
    return app


def _is_api(request: Request) -> bool:
    return request.url.path.startswith("/api/")


async def _bad_parameter(request: Request, exc: Exception) -> Response:
    return JSONResponse({"error": str(exc)}, status_code=400)


async def _unavailable(request: Request, exc: Exception) -> Response:
    return JSONResponse({"error": str(exc)}, status_code=503)


async def _http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    if _is_api(request):
        return JSONResponse({"error": exc.detail}, status_code=exc.status_code)
    return HTMLResponse(pages.error(exc.status_code, exc.detail), status_code=exc.status_code)


def _int(request: Request, name: str, default: int, lo: int, hi: int) -> int:
    text = request.query_params.get(name)
    if text is None or text == "":
        return default
    try:
        value = int(text)
    except ValueError:
        raise BadParameter(f"{name}: expected a whole number, got {text!r}") from None
    if not lo <= value <= hi:
        raise BadParameter(f"{name}: must be between {lo} and {hi}, got {value}")
    return value


def _time(request: Request, name: str) -> str | None:
    text = request.query_params.get(name)
    return None if text is None or text == "" else parse_time(name, text)


def _range(request: Request) -> tuple[str | None, str | None]:
    lo, hi = _time(request, "from"), _time(request, "to")
    if lo is not None and hi is not None and lo > hi:
        raise BadParameter(f"from ({lo}) is after to ({hi})")
    return lo, hi


def _cpu_timed(work: Callable[[store.Db], T], cpu: list[float], db: store.Db) -> T:
    """``work(db)``; ``cpu[0]`` becomes the CPU time its thread spent in it (``work`` puts
    the start there)."""
    try:
        return work(db)
    finally:
        cpu[0] = time.thread_time() - cpu[0]


class Api(AlarmHandlers):
    """The request handlers over one :class:`Settings` (the alarms' in :mod:`.alarm_api`)."""

    settings: Settings

    def __init__(self, settings: Settings) -> None:
        self.settings = settings

    async def _db(self, work: Callable[[store.Db], T]) -> T:
        readings = self.settings.readings

        def run() -> T:
            db = readings.open()
            try:
                return work(db)
            except query_errors() as exc:  # the server went away, the file is busy
                raise store.StoreUnavailable(
                    f"the readings on {readings.where} cannot be read: {exc}"
                ) from exc
            finally:
                readings.close(db)

        return await run_in_threadpool(run)

    async def _known(self, logger: str) -> None:
        if not await self._db(lambda c: store.known(c, logger)):
            raise HTTPException(404, f"unknown logger {logger!r}")

    # pages

    async def page_overview(self, request: Request) -> Response:
        def work(c: store.Db) -> tuple[dict[str, Any], list[dict[str, Any]]]:
            return overview.overview(c), store.sources(c)

        data, sources = await self._db(work)
        shown = await self._alarms_shown(lambda s: alarms.active(s, sources), list[Any]())
        on, unavailable = shown
        refresh = self.settings.overview_refresh_s
        return HTMLResponse(
            pages.overview(data, refresh_s=refresh, alarms=on, unavailable=unavailable)
        )

    async def page_plot(self, request: Request) -> Response:
        logger = request.path_params["logger"]
        await self._known(logger)

        def work(c: store.Db) -> tuple[list[store.Channel], list[dict[str, Any]]]:
            return store.channels(c, logger), store.sources(c)

        chans, sources = await self._db(work)
        changed = await self._db(partial(config_log.changes, logger=logger))
        shown = await self._alarms_shown(lambda s: alarms.active(s, sources), list[Any]())
        on, unavailable = shown
        mine = [a for a in on if a["logger"] == logger]
        return HTMLResponse(
            pages.plot(
                logger,
                [overview.channel_json(c) for c in chans],
                alarms=mine,
                alarm_count=len(on),
                refresh_s=self.settings.overview_refresh_s,
                config_changes=changed,
                unavailable=unavailable,
            )
        )

    async def page_log(self, request: Request) -> Response:
        try:
            before = _int(request, "before", 0, 0, 2**62) or None
        except BadParameter as exc:
            raise HTTPException(400, str(exc)) from None
        source = request.query_params.get("source") or None
        limit = 50

        evs = await self._db(partial(store.events, before=before, limit=limit, source=source))

        def work(s: SqlAlarmStore) -> tuple[list[dict[str, Any]], int]:
            return alarms.history(s), len(s.active_states())

        no_alarms: tuple[list[dict[str, Any]], int] = ([], 0)
        (past, count), unavailable = await self._alarms_shown(work, no_alarms)
        return HTMLResponse(
            pages.log(
                evs,
                source=source,
                limit=limit,
                alarm_history=past,
                alarm_count=count,
                refresh_s=self.settings.overview_refresh_s,
                unavailable=unavailable,
            )
        )

    # JSON

    async def loggers(self, request: Request) -> Response:
        return JSONResponse(await self._db(overview.overview))

    async def logger(self, request: Request) -> Response:
        logger = request.path_params["logger"]
        await self._known(logger)

        def work(c: store.Db) -> dict[str, Any]:
            return overview.logger_json(c, logger, store.sources(c))

        return JSONResponse(await self._db(work))

    async def series(self, request: Request) -> Response:
        logger = request.path_params["logger"]
        lo, hi = _range(request)
        points = _int(request, "points", self.settings.max_points, 10, self.settings.max_points)
        await self._known(logger)
        span = self.settings.default_span_s

        cpu: list[float] = []

        def work(c: store.Db) -> dict[str, Any]:
            cpu.append(time.thread_time())
            return series.answer(c, logger, lo, hi, points, span)

        began = time.perf_counter()
        body = await self._db(partial(_cpu_timed, work, cpu))
        json_cpu = time.thread_time()
        answer = JSONResponse(body)  # the JSON is made here: part of the server's time
        cpu[0] += time.thread_time() - json_cpu
        took = (time.perf_counter() - began) * 1e3
        # wall time, and the CPU time of this request's threads (unaffected by other load)
        answer.headers["Server-Timing"] = f"app;dur={took:.1f}, cpu;dur={cpu[0] * 1e3:.1f}"
        return answer

    async def csv(self, request: Request) -> Response:
        logger = request.path_params["logger"]
        lo, hi = _range(request)
        await self._known(logger)
        readings = self.settings.readings

        def rows() -> Iterator[str]:
            conn = readings.open()
            try:
                buf = io.StringIO()
                out = csv.writer(buf, lineterminator="\n")
                out.writerow(COLUMNS)
                for n, row in enumerate(store.rows_for_csv(conn, logger, lo, hi)):
                    out.writerow(["" if v is None else v for v in row])
                    if n % 1000 == 999:
                        yield buf.getvalue()
                        buf.seek(0)
                        buf.truncate()
                yield buf.getvalue()
            finally:
                readings.close(conn)

        name = re.sub(r"[^A-Za-z0-9._-]", "_", logger)
        return StreamingResponse(
            rows(),
            media_type="text/csv; charset=utf-8",
            headers={"Content-Disposition": f'attachment; filename="{name}.csv"'},
        )

    async def events(self, request: Request) -> Response:
        before = _int(request, "before", 0, 0, 2**62) or None
        limit = _int(request, "limit", 50, 1, 500)
        source = request.query_params.get("source") or None
        evs = await self._db(lambda c: store.events(c, before=before, limit=limit, source=source))
        nxt = evs[-1]["id"] if len(evs) == limit else None
        return JSONResponse({"events": evs, "before": nxt})

    async def stream(self, request: Request) -> Response:
        logger = request.path_params["logger"]
        after = _time(request, "after")
        await self._known(logger)
        if after is None:
            after = await self._db(lambda c: store.last_time(c, logger)) or "0001-01-01T00:00:00"
        return StreamingResponse(
            self._live(logger, after),
            media_type="text/event-stream",
            headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"},
        )

    async def _live(self, logger: str, after: str) -> AsyncIterator[str]:
        """Rows newer than ``after``, as ``readings`` events; this client's own cursor."""
        since, seen = shift(after, 1), set[tuple[int, int]]()
        idle = 0.0
        yield "retry: 2000\nevent: ready\ndata: {}\n\n"
        while not self.settings.stopping:
            rows = await self._db(partial(store.newer, logger=logger, since=since, limit=5000))
            fresh = [r for r in rows if not (r[0] == since and (r[1], r[2]) in seen)]
            if fresh:
                last = fresh[-1][0]
                if last != since:
                    since, seen = last, set()
                seen.update((r[1], r[2]) for r in fresh if r[0] == last)
                data = {"rows": [[to_epoch(t), ch, v] for t, _, ch, v in fresh], "last": last}
                yield f"event: readings\ndata: {json.dumps(data)}\n\n"
                idle = 0.0
            elif idle >= self.settings.heartbeat_s:
                yield ": ping\n\n"
                idle = 0.0
            await asyncio.sleep(self.settings.poll_interval)
            idle += self.settings.poll_interval
