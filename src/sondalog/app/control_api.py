"""The control API of ``sondalog serve --control HOST:PORT`` (issue 23; docs/control.md).

An HTTP JSON API over a served site, in the style of the GSM network's
(:mod:`sondalog.app.gsm_api`: the same server, body limit and error shape):

==================================  =========================================================
``GET /health``                     ``{"ok": true, "devices": N}``
``GET /openapi.json``               the OpenAPI 3.1 description of this API
``GET /devices``                    every device: name, kind, power, active faults
``GET /devices/NAME``               one device: its inputs now, module time, record rows,
                                    faults, snapshots
``POST /devices/NAME/ACTION``       ACTION: set, fault, clear, restart, snapshot, restore
                                    (the body: :func:`~sondalog.app.control_actions.parse_action`)
``GET /time``                       the site's clock: now, paused, speed
``POST /time/ACTION``               pause, resume, speed ``{"factor"}``, step ``{"seconds"}``
==================================  =========================================================

Every error is ``{"error": "...", "field": NAME | null}``: a body that is not a JSON object,
an unknown or misspelt field, a value of the wrong type or out of range: 400 naming the
field; an unknown device, input or snapshot: 404; an action the device's state refuses (a
fault already active, a logger without power, a real board's inputs): 409; a body larger
than :data:`~sondalog.app.gsm_api.MAX_BODY` bytes: 413. A refused request changes nothing.
Bodies are read through the configuration reader (:func:`sondalog.config.of`). Without a
token the API listens on loopback only; with ``--allow-remote`` it needs one
(:class:`BearerGate`: ``Authorization: Bearer <token>``, else a JSON 401).
"""

from __future__ import annotations

import hmac
import json

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route
from starlette.types import ASGIApp, Receive, Scope, Send

from sondalog.app.control import Controller
from sondalog.app.control_actions import parse_action, parse_time
from sondalog.app.control_logger import Refusal
from sondalog.app.control_openapi import openapi
from sondalog.app.gsm_api import MAX_DEPTH, BodyLimit, error_response
from sondalog.app.http_api import HttpApi
from sondalog.app.serve import RunningSite
from sondalog.config import ConfigError, Table, of
from sondalog.io.clock import Clock

DEVICE_ACTIONS = ("set", "fault", "clear", "restart", "snapshot", "restore")
TIME_ACTIONS = ("pause", "resume", "speed", "step")


class BearerGate:
    """ASGI middleware: every request carries ``Authorization: Bearer <token>`` (the
    dashboard's rule, :mod:`sondalog.web.auth`), else a JSON 401."""

    def __init__(self, app: ASGIApp, token: str) -> None:
        self.app = app
        self.token = token.encode()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http":
            given = dict(scope["headers"]).get(b"authorization", b"")
            bearer = given[7:].strip() if given[:7].lower() == b"bearer " else b""
            if not hmac.compare_digest(bearer, self.token):
                refused = error_response(
                    401, "a token is required: 'Authorization: Bearer <token>'"
                )
                refused.headers["WWW-Authenticate"] = "Bearer"
                await refused(scope, receive, send)
                return
        await self.app(scope, receive, send)


def _no_constant(name: str) -> object:
    raise ValueError(f"{name} is not JSON")


def _depth(value: object) -> int:
    """How deep objects and arrays nest in the parsed ``value`` (no recursion)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict | list):
            deepest = max(deepest, level + 1)
            stack.extend(
                (v, level + 1) for v in (item.values() if isinstance(item, dict) else item)
            )
    return deepest


async def _body(request: Request) -> Table:
    """The request's JSON object (an empty body: ``{}``) as a table of the config reader."""
    raw = await request.body()  # BodyLimit has read it: at most MAX_BODY bytes
    not_object = Refusal(400, "the body must be a JSON object")
    if not raw.strip():
        return of({"body": {}}).table("body")
    try:
        data = json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
    except (ValueError, RecursionError):  # not UTF-8, not JSON, nested beyond recursion
        raise not_object from None
    if not isinstance(data, dict):
        raise not_object
    if _depth(data) > MAX_DEPTH:
        raise Refusal(400, f"the body nests deeper than {MAX_DEPTH} levels")
    try:
        return of({"body": data}).table("body")
    except ConfigError:
        raise not_object from None


def build_app(control: Controller, token: str | None = None) -> Starlette:
    """The API over ``control``; with ``token``, every request must carry it."""

    async def health(request: Request) -> JSONResponse:
        return JSONResponse({"ok": True, "devices": len(control.names())})

    async def spec(request: Request) -> JSONResponse:
        return JSONResponse(openapi())

    async def devices(request: Request) -> JSONResponse:
        return JSONResponse(control.devices())

    async def device(request: Request) -> JSONResponse:
        return JSONResponse(control.describe(str(request.path_params["name"])))

    async def device_action(request: Request) -> JSONResponse:
        name, action = str(request.path_params["name"]), str(request.path_params["action"])
        if action not in DEVICE_ACTIONS:
            raise Refusal(404, f"no action {action[:40]!r} (actions: {', '.join(DEVICE_ACTIONS)})")
        if not control.is_device(name):
            control.logger(name)  # the 404 naming the devices
        body = await _body(request)
        return JSONResponse(await control.apply(parse_action(action, name, body, remote=True)))

    async def time(request: Request) -> JSONResponse:
        return JSONResponse(control.time())

    async def time_action(request: Request) -> JSONResponse:
        action = str(request.path_params["action"])
        if action not in TIME_ACTIONS:
            raise Refusal(
                404, f"no time action {action[:40]!r} (actions: {', '.join(TIME_ACTIONS)})"
            )
        body = await _body(request)
        return JSONResponse(await control.apply(parse_time(action, body)))

    async def refused(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, Refusal)
        return error_response(exc.status, exc.message, exc.field)

    async def bad_body(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ConfigError)  # from the reader: field "body.NAME"
        field = exc.field.removeprefix("body").removeprefix(".") or None
        return error_response(400, f"{field or 'body'}: {exc.message}", field)

    async def http_error(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, HTTPException)  # an unknown path (404), a wrong method (405)
        return error_response(exc.status_code, str(exc.detail))

    async def internal(request: Request, exc: Exception) -> JSONResponse:
        return error_response(500, "internal error (see the server's log)")

    routes = [
        Route("/health", health),
        Route("/openapi.json", spec),
        Route("/devices", devices),
        Route("/devices/{name}", device),
        Route("/devices/{name}/{action}", device_action, methods=["POST"]),
        Route("/time", time),
        Route("/time/{action}", time_action, methods=["POST"]),
    ]
    handlers = {
        Refusal: refused,
        ConfigError: bad_body,
        HTTPException: http_error,
        Exception: internal,
    }
    middleware = [Middleware(BodyLimit)]
    if token is not None:
        middleware.insert(0, Middleware(BearerGate, token=token))
    return Starlette(routes=routes, middleware=middleware, exception_handlers=handlers)


async def start_control(
    site: RunningSite | Controller, clock: Clock, host: str, port: int, token: str | None = None
) -> ControlServer:
    """The control API over ``site`` (or its controller: one a scenario runs on) on
    ``host:port``, started."""
    control = site if isinstance(site, Controller) else Controller(site, clock)
    server = ControlServer(control, host, port, token)
    await server.start()
    return server


class ControlServer(HttpApi):
    """The control API (:func:`build_app`) on a socket bound here (errors raise OSError)."""

    what = "the control API"

    def __init__(self, control: Controller, host: str, port: int, token: str | None = None) -> None:
        self.control = control
        super().__init__(build_app(control, token), host, port)

    async def stop(self) -> None:
        await super().stop()
        await self.control.close()
