"""The dashboard's alarm requests (issue 21): ``GET /api/alarms`` and
``POST /api/alarms/{alarm}/ack``; the queries and the same-origin check are in
:mod:`.alarms`.

Both go to the collector's alarm store wherever it is (its SQLite file, or the
``[postgres]`` server with ``alarms = true``: :class:`~.alarms.AlarmAccess`). The
acknowledgement is the dashboard's one write (``request_ack``); the collector applies it on
its next turn (``take_ack_requests``).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TypeVar
from urllib.parse import urlsplit

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, RedirectResponse, Response

from sondalog.collect.alarms.store import SqlAlarmStore
from sondalog.config import ConfigError, of

from . import alarms, store

log = logging.getLogger(__name__)


class Settings(Protocol):
    """What the alarm requests need of :class:`~.app.Settings`."""

    store: Path | None
    token: str | None
    alarms: alarms.AlarmAccess


T = TypeVar("T")


def _ack_by(body: bytes) -> str:
    """Who asks, from an optional JSON body ``{"by": "NAME"}`` (default ``dashboard``)."""
    if not body.strip():
        return "dashboard"
    try:
        data = json.loads(body)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(None, "body", f"not JSON: {exc}") from None
    table = of({"body": data}).table("body", ["by"])
    return table.text(
        "by", "dashboard", pattern=r"[^\x00-\x1f\x7f]{1,80}", what="1 to 80 characters"
    )


def _not_raised(alarm: str, state: str) -> Response:
    message = f"alarm {alarm} is {state}, not raised: only a raised alarm can be acknowledged"
    return JSONResponse({"error": message, "state": state}, status_code=409)


class AlarmHandlers:
    """The alarm requests of :class:`~.app.Api` (which gives ``settings`` and ``_db``)."""

    settings: Settings

    async def _db(self, work: Callable[[store.Db], T]) -> T:
        raise NotImplementedError

    async def _alarms(
        self, work: Callable[[SqlAlarmStore], T], default: T, *, write: bool = False
    ) -> T:
        """``work`` on the collector's alarm store in a worker thread (``default``: it has
        no alarm tables yet); raises ``StoreUnavailable`` (503) when it cannot be read."""
        return await run_in_threadpool(self.settings.alarms.run, work, default, write=write)

    async def _alarms_shown(
        self, work: Callable[[SqlAlarmStore], T], default: T
    ) -> tuple[T, str | None]:
        """As :meth:`_alarms` for a page: an alarm store that cannot be read (the
        ``[postgres]`` server is down) leaves the page without its alarms, and says so in
        the log, rather than failing the whole page with the readings. Returns the value
        (``default`` then) and why the alarms are unavailable (None: they were read), so
        the page says "alarms unavailable" rather than "no active alarms"."""
        try:
            return await self._alarms(work, default), None
        except store.StoreUnavailable as exc:
            log.warning("dashboard: %s", exc)
            # the page names the store, not the driver's message (it may name a user)
            return default, f"the alarms on {self.settings.alarms.where} cannot be read now"

    async def alarm_list(self, request: Request) -> Response:
        """The active alarms and the latest transitions (``?logger=``: that logger's)."""
        logger = request.query_params.get("logger") or None

        sources = await self._db(store.sources)

        def work(s: SqlAlarmStore) -> dict[str, Any]:
            return {"active": alarms.active(s, sources), "history": alarms.history(s)}

        found: dict[str, Any] = await self._alarms(work, {"active": [], "history": []})
        if logger is not None:
            on = [a for a in found["active"] if a["logger"] == logger]
            names = {a["id"] for a in on}
            loggers = {str(s["name"]): str(s["logger"]) for s in sources if s.get("logger")}
            past = [
                h
                for h in found["history"]
                if h["id"] in names or alarms.logger_of(str(h["subject"]), loggers) == logger
            ]
            found = {"active": on, "history": past}
        return JSONResponse(found)

    async def ack(self, request: Request) -> Response:
        """Ask the collector to acknowledge a raised alarm (202; it applies it on its next
        turn). Cross-site 403, unknown alarm 404, an alarm not raised now 409."""
        headers = {k.lower(): v for k, v in request.headers.items()}
        refused = alarms.cross_site(headers, token_set=self.settings.token is not None)
        if refused is not None:
            return JSONResponse({"error": refused}, status_code=403)
        alarm = request.path_params["alarm"]
        # the button without JavaScript: a browser's form POST, answered with the page
        form = headers.get("content-type", "").startswith("application/x-www-form-urlencoded")
        form = form and "text/html" in headers.get("accept", "")
        try:
            by = "dashboard" if form else _ack_by(await request.body())
        except ConfigError as exc:
            return JSONResponse({"error": str(exc)}, status_code=400)
        state = await self._alarms(lambda s: s.state_of(alarm), None)
        if state is None:
            return JSONResponse({"error": f"unknown alarm {alarm!r}"}, status_code=404)
        if state != "raised":
            return _not_raised(alarm, state)
        now = time.time()
        asked = await self._alarms(lambda s: s.request_ack(alarm, by, now), False, write=True)
        if not asked:  # changed in the meantime
            state = await self._alarms(lambda s: s.state_of(alarm), None)
            return _not_raised(alarm, state or "gone")
        if form:  # back to the page it was on
            back = urlsplit(headers.get("referer", "/"))
            return RedirectResponse(
                (back.path or "/") + (f"?{back.query}" if back.query else ""), 303
            )
        body = {"alarm": alarm, "ack_requested": True, "by": by, "requested": now}
        return JSONResponse(body, status_code=202)
