"""A phone of the simulated GSM network, through the network's HTTP JSON API (docs/gsm.md).

:class:`PhoneApi` is what ``sondalog phone ...`` uses (stdlib ``urllib`` only): send an SMS,
list the SMS a number received, place a voice or data call. :class:`GsmEndpoint` is the
``gsm://API-HOST:PORT/NUMBER?from=PHONE`` URL of ``sondalog term``: it places a data call from
PHONE to NUMBER, connects to the call's bridge port and waits until the modem answered.
"""

from __future__ import annotations

import asyncio
import json
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar
from urllib.parse import quote, unquote, urlsplit

DEFAULT_API = "http://127.0.0.1:8025"
#: The largest request body the API reads (``sondalog.app.gsm_api`` takes it from here;
#: docs/gsm.md).
MAX_BODY = 64 * 1024
#: How long a data call may ring before ``sondalog term`` gives up (the network: 60 s).
ANSWER_TIMEOUT = 65.0

_P = TypeVar("_P", bound=asyncio.Protocol)


class PhoneApiError(Exception):
    """The API refused (``status`` 4xx with its message) or cannot be reached (0)."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.message = message


class PhoneApi:
    """The network's HTTP API at ``base`` (e.g. ``http://127.0.0.1:8025``)."""

    def __init__(self, base: str = DEFAULT_API, timeout: float = 10.0) -> None:
        self.base = base.rstrip("/")
        self.timeout = timeout

    def request(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        data = None if body is None else json.dumps(body).encode()
        if data is not None and len(data) > MAX_BODY:  # the API would cut the connection
            raise PhoneApiError(413, f"the request is larger than the API takes ({MAX_BODY} bytes)")
        req = urllib.request.Request(self.base + path, data=data, method=method)
        req.add_header("Content-Type", "application/json")
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as response:
                return json.loads(response.read() or b"null")
        except urllib.error.HTTPError as exc:
            try:
                message = str(json.loads(exc.read())["error"])
            except (ValueError, KeyError, TypeError):
                message = f"HTTP {exc.code}"
            raise PhoneApiError(exc.code, message) from None
        except (urllib.error.URLError, OSError) as exc:
            reason = getattr(exc, "reason", exc)
            raise PhoneApiError(
                0, f"cannot reach the network API at {self.base}: {reason}"
            ) from None

    def sms(self, sender: str, to: str, text: str) -> dict[str, Any]:
        result: dict[str, Any] = self.request(
            "POST", "/sms", {"from": sender, "to": to, "text": text}
        )
        return result

    def inbox(self, number: str, queued: bool = False) -> list[dict[str, Any]]:
        path = f"/sms?to={quote(number)}" + ("&queued=1" if queued else "")
        result: list[dict[str, Any]] = self.request("GET", path)
        return result

    def call(self, sender: str, to: str, kind: str) -> dict[str, Any]:
        result: dict[str, Any] = self.request(
            "POST", "/call", {"from": sender, "to": to, "kind": kind}
        )
        return result

    def get_call(self, call_id: int) -> dict[str, Any]:
        result: dict[str, Any] = self.request("GET", f"/calls/{call_id}")
        return result

    def hang_up(self, call_id: int) -> dict[str, Any]:
        result: dict[str, Any] = self.request("DELETE", f"/calls/{call_id}")
        return result

    def coverage(self, number: str | None, covered: bool) -> dict[str, Any]:
        result: dict[str, Any] = self.request(
            "POST", "/coverage", {"number": number, "covered": covered}
        )
        return result

    def subscribers(self) -> list[dict[str, Any]]:
        result: list[dict[str, Any]] = self.request("GET", "/subscribers")
        return result


@dataclass(frozen=True)
class GsmEndpoint:
    """A data call from phone ``caller`` to modem ``number`` through the API at ``api``."""

    api: str
    number: str
    caller: str

    async def connect(self, factory: Callable[[], _P]) -> tuple[asyncio.BaseTransport, _P]:
        phone = PhoneApi(self.api)
        try:
            call = await asyncio.to_thread(phone.call, self.caller, self.number, "data")
        except PhoneApiError as exc:
            raise OSError(exc.message) from None
        if call.get("state") == "ended" or "bridge" not in call:
            raise OSError(f"the call ended: {call.get('reason', 'no carrier')}")
        loop = asyncio.get_running_loop()
        transport, protocol = await loop.create_connection(factory, "127.0.0.1", call["bridge"])
        deadline = time.monotonic() + ANSWER_TIMEOUT
        while call.get("state") == "ringing" and time.monotonic() < deadline:
            await asyncio.sleep(0.1)
            call = await asyncio.to_thread(phone.get_call, int(call["call"]))
        if call.get("state") != "connected":
            transport.close()
            raise OSError(f"the call ended: {call.get('reason', 'no answer')}")
        return transport, protocol

    def __str__(self) -> str:
        return f"gsm://{urlsplit(self.api).netloc}/{quote(self.number)}?from={quote(self.caller)}"


def parse_gsm_url(url: str) -> GsmEndpoint:
    """``gsm://HOST:PORT/NUMBER?from=PHONE`` (HOST:PORT: the API, default 127.0.0.1:8025)."""
    parts = urlsplit(url)
    number = unquote(parts.path.lstrip("/"))
    # unquote, not parse_qs: a "+" in "from=+420..." is the number's plus, not a space
    options = dict(p.partition("=")[::2] for p in parts.query.split("&") if p)
    caller = unquote(options.get("from", ""))
    if not number or not caller or set(options) - {"from"}:
        raise ValueError(f"expected gsm://HOST:PORT/NUMBER?from=PHONE, got {url!r}")
    netloc = parts.netloc or "127.0.0.1:8025"
    return GsmEndpoint(f"http://{netloc}", number, caller)
