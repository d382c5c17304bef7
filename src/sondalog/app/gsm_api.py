"""The GSM network's HTTP JSON API (issue 12; ``docs/gsm.md`` "The HTTP API").

Served on loopback by uvicorn inside the ``sondalog serve`` event loop (default
``127.0.0.1:8025``):

=========================  ===============================================================
``GET /health``            ``{"ok": true, "subscribers": N}``
``GET /subscribers``       every subscriber: number, kind, registered, coverage, signal,
                           credit, queued SMS, published ports
``POST /sms``              ``{"from", "to", "text"}``: a phone sends an SMS -> 201
                           ``{"ids": [...], "queued": bool}``
``GET /sms?to=NUMBER``     the SMS delivered to NUMBER, oldest first (``from``, ``to``,
                           ``text``, ``time``: ISO 8601 UTC, ``id``; ``part``: [seq, total]
                           of an incomplete concatenated SMS); ``&queued=1``: waiting
``POST /call``             ``{"from", "to", "kind": "voice" | "data"}`` -> 201, the call
                           (``state``, ``reason``, ``bridge``: the data port)
``GET /calls``             the calls phones placed (``GET /calls/ID`` one of them);
                           ``DELETE /calls/ID`` hangs up
``POST /coverage``         ``{"number": N | null, "covered": bool}`` (null: everyone)
=========================  ===============================================================

Bad input gets 400 with ``{"error": "..."}``, an unknown number 404.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import Iterator
from datetime import UTC, datetime
from typing import Any

import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route

from sondalog.app.gsm import GsmRuntime
from sondalog.gsm.network import MODEM, PHONE
from sondalog.gsm.sms import Sms, joined, normalize

#: The longest text ``POST /sms`` takes (a concatenated SMS of at most 255 parts is far more).
MAX_TEXT = 4000


class ApiError(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


def _sms_json(sms: Sms) -> dict[str, Any]:
    out: dict[str, Any] = {
        "id": sms.sms_id,
        "from": sms.sender,
        "to": sms.to,
        "text": sms.text,
        "time": datetime.fromtimestamp(sms.timestamp, tz=UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
    if sms.concat is not None:  # a part of a concatenated SMS whose other parts are missing
        out["part"] = [sms.concat.seq, sms.concat.total]
    return out


async def _body(request: Request) -> dict[str, Any]:
    try:
        data = await request.json()
    except ValueError:
        raise ApiError(400, "the body must be a JSON object") from None
    if not isinstance(data, dict):
        raise ApiError(400, "the body must be a JSON object")
    return data


def _text(data: dict[str, Any], key: str) -> str:
    value = data.get(key)
    if not isinstance(value, str) or not value:
        raise ApiError(400, f"{key!r} must be a non-empty string")
    return value


def build_app(runtime: GsmRuntime) -> Starlette:
    """The API over a running :class:`GsmRuntime`."""

    def subscriber(number: str, kinds: tuple[str, ...] = (MODEM, PHONE)) -> str:
        n = normalize(number)
        if not (n.startswith("+") and n[1:].isdigit()):
            raise ApiError(400, f"{number!r} is not a phone number like +420700000001")
        sub = runtime.network.subscribers.get(n)
        if sub is None or sub.kind not in kinds:
            raise ApiError(404, f"{n} is not a {' or '.join(kinds)} of this network")
        return n

    async def health(request: Request) -> JSONResponse:
        return JSONResponse({"ok": True, "subscribers": len(runtime.network.subscribers)})

    async def subscribers(request: Request) -> JSONResponse:
        net = runtime.network
        out = []
        for sub in net.subscribers.values():
            out.append(
                {
                    "number": sub.number,
                    "kind": sub.kind,
                    "registered": sub.registered,
                    "radio": sub.radio,
                    "covered": sub.covered,
                    "signal": sub.rssi,
                    "credit": round(sub.credit, 2),
                    "queued": len(sub.queue),
                    "delivered": len(sub.delivered),
                    "attached": sub.attached,
                    "published": {
                        str(p): h for (n, p), h in net.gateway.published.items() if n == sub.number
                    },
                    "listening": net.gateway.listening(sub.number),
                }
            )
        return JSONResponse(out)

    async def send_sms(request: Request) -> JSONResponse:
        data = await _body(request)
        sender, to, text = (_text(data, k) for k in ("from", "to", "text"))
        if len(text) > MAX_TEXT:
            raise ApiError(400, f"'text' is longer than {MAX_TEXT} characters")
        sender, to = subscriber(sender, (PHONE,)), subscriber(to)
        before = runtime.network._next_sms
        runtime.network_call(runtime.network.phone_sms(sender, to, text, runtime.clock.now()))
        ids = list(range(before, runtime.network._next_sms))
        queued = any(s.sms_id in ids for s in runtime.network.queued(to))
        return JSONResponse({"ids": ids, "queued": queued}, status_code=201)

    async def list_sms(request: Request) -> JSONResponse:
        to = request.query_params.get("to")
        if not to or not to.strip():
            raise ApiError(400, "give the number: /sms?to=NUMBER")
        if to.startswith(" "):  # ?to=+420...: the form encoding made the plus a space
            to = "+" + to.lstrip()
        number = subscriber(to)
        if request.query_params.get("queued") in ("1", "true", "yes"):
            messages = runtime.network.queued(number)
        else:
            messages = joined(runtime.network.delivered(number))
        return JSONResponse([_sms_json(s) for s in messages])

    async def call(request: Request) -> JSONResponse:
        data = await _body(request)
        caller, callee = _text(data, "from"), _text(data, "to")
        kind = data.get("kind", "voice")
        if kind not in ("voice", "data"):
            raise ApiError(400, '\'kind\' must be "voice" or "data"')
        caller, callee = subscriber(caller, (PHONE,)), subscriber(callee)
        info = await runtime.calls.place(caller, callee, kind)
        return JSONResponse(info.as_json(), status_code=201)

    async def calls(request: Request) -> JSONResponse:
        return JSONResponse([c.as_json() for c in runtime.calls.calls.values()])

    def call_id(request: Request) -> int:
        raw = str(request.path_params["call_id"])
        if not raw.isdigit() or int(raw) not in runtime.calls.calls:
            raise ApiError(404, f"no call {raw}")
        return int(raw)

    async def one_call(request: Request) -> JSONResponse:
        return JSONResponse(runtime.calls.calls[call_id(request)].as_json())

    async def hang_up(request: Request) -> JSONResponse:
        number = call_id(request)
        runtime.calls.hang_up(number)
        return JSONResponse(runtime.calls.calls[number].as_json())

    async def coverage(request: Request) -> JSONResponse:
        data = await _body(request)
        number = data.get("number")
        covered = data.get("covered")
        if not isinstance(covered, bool):
            raise ApiError(400, "'covered' must be true or false")
        if number is not None:
            if not isinstance(number, str):
                raise ApiError(400, "'number' must be a phone number or null")
            number = subscriber(number)
        now = runtime.clock.now()
        runtime.network_call(runtime.network.set_coverage(number, covered, now))
        return JSONResponse({"number": number, "covered": covered})

    async def error(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ApiError)
        return JSONResponse({"error": exc.message}, status_code=exc.status)

    routes = [
        Route("/health", health),
        Route("/subscribers", subscribers),
        Route("/sms", send_sms, methods=["POST"]),
        Route("/sms", list_sms, methods=["GET"]),
        Route("/call", call, methods=["POST"]),
        Route("/calls", calls),
        Route("/calls/{call_id}", one_call, methods=["GET"]),
        Route("/calls/{call_id}", hang_up, methods=["DELETE"]),
        Route("/coverage", coverage, methods=["POST"]),
    ]
    return Starlette(routes=routes, exception_handlers={ApiError: error})


class _Server(uvicorn.Server):
    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield  # the serve loop owns SIGINT and SIGTERM


class ApiServer:
    """uvicorn serving :func:`build_app` on a socket bound here (errors raise OSError)."""

    def __init__(self, runtime: GsmRuntime, host: str, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.sock.bind((host, port))
        except OSError:
            self.sock.close()
            raise
        self.sock.listen(128)
        config = uvicorn.Config(
            build_app(runtime), log_level="warning", lifespan="off", access_log=False
        )
        self.server = _Server(config)
        self.task: asyncio.Task[None] | None = None

    @property
    def address(self) -> tuple[str, int]:
        name = self.sock.getsockname()
        return str(name[0]), int(name[1])

    async def start(self) -> None:
        self.task = asyncio.get_running_loop().create_task(self.server.serve([self.sock]))
        while not self.server.started:
            if self.task.done():
                self.task.result()
                raise OSError("the HTTP API did not start")
            await asyncio.sleep(0.01)

    async def stop(self) -> None:
        self.server.should_exit = True
        if self.task is not None:
            with contextlib.suppress(Exception):
                await self.task
        self.sock.close()
