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

Every error is JSON, ``{"error": "...", "field": NAME | null}`` (``field``: the body's field at
fault): a body that is not a JSON object, nests deeper than :data:`MAX_DEPTH`, lacks a field,
has an unknown field, a field of the wrong type or a string that is not text (a lone surrogate
such as ``"\\ud800"``) gets 400 and changes nothing; an unknown number 404; a body larger than
:data:`MAX_BODY` bytes 413 (no more than that is read; the connection closes). A body is read
through the configuration reader (:func:`sondalog.config.of`, the fields named ``body.NAME``
in messages).

Requests are posted to the network's host through :class:`~sondalog.app.gsm.GsmRuntime`
(``send_sms``, ``set_coverage``, the call bridges); the ids in an answer are the ones the
network gave in its output.
"""

from __future__ import annotations

import json
import re
from datetime import UTC, datetime
from typing import Any

from starlette.applications import Starlette
from starlette.datastructures import Headers
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from sondalog.app.gsm import GsmRuntime
from sondalog.app.http_api import HttpApi
from sondalog.client.phone import MAX_BODY  # one limit: the client checks it before sending
from sondalog.config import ConfigError, Table, of
from sondalog.gsm.network import MODEM, PHONE
from sondalog.gsm.sms import Sms, joined, normalize

#: The longest text ``POST /sms`` takes (a concatenated SMS of at most 255 parts is far more).
MAX_TEXT = 4000
#: The largest request body read, in bytes; a larger one gets 413.
#: The deepest nesting of a request body (objects and arrays); a request needs 1.
MAX_DEPTH = 32


class ApiError(Exception):
    """A refused request: ``status``, a message and the body's ``field`` at fault (or None)."""

    def __init__(self, status: int, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.field = field


def _safe(text: str) -> str:
    """``text`` with lone surrogates as backslash escapes: it always encodes."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8")


def error_response(status: int, message: str, field: str | None = None) -> JSONResponse:
    """``{"error": message, "field": field}``; a message (or an unknown field's name) with a
    lone surrogate still encodes (backslash escapes), so an error never becomes a 500."""
    headers = {"connection": "close"} if status == 413 else None
    body = {"error": _safe(message), "field": None if field is None else _safe(field)}
    return JSONResponse(body, status_code=status, headers=headers)


class BodyLimit:
    """ASGI middleware: reads a request's whole body, at most ``limit`` bytes, before the
    app sees it. A larger body (by its Content-Length or as it arrives) gets 413 at once and
    the connection closes: the rest is never read."""

    def __init__(self, app: ASGIApp, limit: int = MAX_BODY) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        too_large = error_response(413, f"the body is larger than {self.limit} bytes")
        declared = Headers(scope=scope).get("content-length", "")
        if declared.isdigit() and int(declared) > self.limit:
            await too_large(scope, receive, send)
            return
        chunks: list[bytes] = []
        size = 0
        more = True
        while more:
            message = await receive()
            if message["type"] == "http.disconnect":
                return  # the client went away: nobody to answer
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.limit:
                await too_large(scope, receive, send)
                return
            chunks.append(chunk)
            more = bool(message.get("more_body", False))
        body = b"".join(chunks)
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if replayed:
                return await receive()
            replayed = True
            return {"type": "http.request", "body": body, "more_body": False}

        await self.app(scope, replay, send)


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


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


#: A JSON string (its escapes included) or anything that is not a bracket.
_NOT_BRACKET = re.compile(r'"(?:[^"\\]|\\.)*"?|[^\[\]{}"]+')


def _nesting(text: str) -> int:
    """How deep objects and arrays nest in the JSON ``text`` (0: a scalar), counted on the
    text before it is parsed (no recursion, and the parser never sees a deeper one)."""
    deepest = depth = 0
    for bracket in _NOT_BRACKET.sub("", text):
        if bracket in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif bracket in "]}":
            depth -= 1
    return deepest


async def _body(request: Request, keys: set[str]) -> Table:
    """The request's JSON object (UTF-8, no NaN or Infinity, nesting <= :data:`MAX_DEPTH`)
    as a reader's table holding only ``keys``: its fields are read through typed getters."""
    raw = await request.body()  # BodyLimit has read it: at most MAX_BODY bytes
    not_object = ApiError(400, "the body must be a JSON object")
    try:
        text = raw.decode("utf-8")
        if _nesting(text) > MAX_DEPTH:
            raise ApiError(400, f"the body nests deeper than {MAX_DEPTH} levels")
        data = json.loads(text, parse_constant=_no_constant)
        return of({"body": data}).table("body").keys(keys)
    except ApiError:
        raise
    except ConfigError as exc:
        if exc.field != "body":
            raise  # an unknown key: named
        raise not_object from None
    except (ValueError, RecursionError):  # not UTF-8, not JSON, an int too long
        raise not_object from None


def _text(body: Table, key: str, what: str | None = None) -> str:
    """A non-empty string of characters: a lone surrogate (``"\\ud800"``) cannot be sent
    or stored."""
    value = body.text(key, what=what)
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        bad = f"U+{ord(value[exc.start]):04X}"
        raise body.fail(key, f"has a lone surrogate {bad}: not a character") from None
    return value


def build_app(runtime: GsmRuntime) -> Starlette:
    """The API over a running :class:`GsmRuntime`."""

    def subscriber(number: str, field: str | None, kinds: tuple[str, ...] = (MODEM, PHONE)) -> str:
        n = normalize(number)
        if not (n.startswith("+") and n[1:].isascii() and n[1:].isdigit()):
            raise ApiError(400, f"{number!r} is not a phone number like +420700000001", field)
        sub = runtime.network.subscribers.get(n)
        if sub is None or sub.kind not in kinds:
            raise ApiError(404, f"{n} is not a {' or '.join(kinds)} of this network", field)
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
        body = await _body(request, {"from", "to", "text"})
        sender, to, text = (_text(body, k) for k in ("from", "to", "text"))
        if len(text) > MAX_TEXT:
            raise body.fail("text", f"is longer than {MAX_TEXT} characters")
        sender, to = subscriber(sender, "from", (PHONE,)), subscriber(to, "to")
        submitted = runtime.send_sms(sender, to, text)
        answer = {"ids": list(submitted.sms_ids), "queued": submitted.queued}
        return JSONResponse(answer, status_code=201)

    async def list_sms(request: Request) -> JSONResponse:
        to = request.query_params.get("to")
        if not to or not to.strip():
            raise ApiError(400, "give the number: /sms?to=NUMBER")
        if to.startswith(" "):  # ?to=+420...: the form encoding made the plus a space
            to = "+" + to.lstrip()
        number = subscriber(to, None)
        if request.query_params.get("queued") in ("1", "true", "yes"):
            messages = runtime.network.queued(number)
        else:
            messages = joined(runtime.network.delivered(number))
        return JSONResponse([_sms_json(s) for s in messages])

    async def call(request: Request) -> JSONResponse:
        body = await _body(request, {"from", "to", "kind"})
        caller, callee = _text(body, "from"), _text(body, "to")
        kind = body.text("kind", "voice", choices=("voice", "data"))
        caller, callee = subscriber(caller, "from", (PHONE,)), subscriber(callee, "to")
        info = await runtime.calls.place(caller, callee, kind)
        return JSONResponse(info.as_json(), status_code=201)

    async def calls(request: Request) -> JSONResponse:
        return JSONResponse([c.as_json() for c in runtime.calls.calls.values()])

    def call_id(request: Request) -> int:
        raw = str(request.path_params["call_id"])
        if not (raw.isascii() and raw.isdigit() and len(raw) < 19):  # int() of 5000 digits raises
            raise ApiError(404, f"no call {raw[:20]!r}")
        if int(raw) not in runtime.calls.calls:
            raise ApiError(404, f"no call {raw}")
        return int(raw)

    async def one_call(request: Request) -> JSONResponse:
        return JSONResponse(runtime.calls.calls[call_id(request)].as_json())

    async def hang_up(request: Request) -> JSONResponse:
        number = call_id(request)
        runtime.calls.hang_up(number)
        return JSONResponse(runtime.calls.calls[number].as_json())

    async def coverage(request: Request) -> JSONResponse:
        body = await _body(request, {"number", "covered"})
        if "number" not in body:  # a misspelt key must not cut the whole network
            raise body.fail("number", "required (null: the whole network)")
        number = None
        if body.raw("number") is not None:
            number = subscriber(_text(body, "number", "a phone number or null"), "number")
        covered = body.flag("covered")
        runtime.set_coverage(number, covered)
        return JSONResponse({"number": number, "covered": covered})

    async def error(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ApiError)
        return error_response(exc.status, exc.message, exc.field)

    async def bad_body(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, ConfigError)  # from the reader: field "body.NAME"
        return error_response(400, f"{exc.field}: {exc.message}", exc.field.removeprefix("body."))

    async def http_error(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, HTTPException)  # an unknown path (404), a wrong method (405)
        return error_response(exc.status_code, str(exc.detail))

    async def internal(request: Request, exc: Exception) -> JSONResponse:
        # a bug: Starlette still raises it after this answer, uvicorn logs the traceback
        return error_response(500, "internal error (see the server's log)")

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
    handlers = {
        ApiError: error,
        ConfigError: bad_body,
        HTTPException: http_error,
        Exception: internal,
    }
    return Starlette(routes=routes, middleware=[Middleware(BodyLimit)], exception_handlers=handlers)


class ApiServer(HttpApi):
    """The GSM network's HTTP API (:func:`build_app`) on a socket bound here (errors raise
    OSError)."""

    def __init__(self, runtime: GsmRuntime, host: str, port: int) -> None:
        super().__init__(build_app(runtime), host, port)
