"""The token gate: with a token set, every request must carry it.

Accepted as ``Authorization: Bearer <token>``, as ``?token=<token>`` (then a cookie is set
so that the pages' own requests, including the live stream, carry it), or as that cookie.
Without a token configured (the loopback default) every request passes.
"""

from __future__ import annotations

import hmac
from collections.abc import Callable
from http.cookies import SimpleCookie
from urllib.parse import parse_qs

from starlette.responses import PlainTextResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

COOKIE = "sondalog_token"


def _matches(given: str | None, token: str) -> bool:
    return given is not None and hmac.compare_digest(given.encode(), token.encode())


class TokenGate:
    """ASGI middleware; ``token()`` gives the current token (None: open)."""

    def __init__(self, app: ASGIApp, token: Callable[[], str | None]) -> None:
        self.app = app
        self.token = token

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        token = self.token()
        if scope["type"] != "http" or token is None:
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1"): v.decode("latin-1") for k, v in scope["headers"]}
        auth = headers.get("authorization", "")
        bearer = auth[7:].strip() if auth[:7].lower() == "bearer " else None
        query = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [None])[0]
        cookies = SimpleCookie()
        cookies.load(headers.get("cookie", ""))
        cookie = cookies[COOKIE].value if COOKIE in cookies else None
        if _matches(bearer, token) or _matches(cookie, token):
            await self.app(scope, receive, send)
            return
        if _matches(query, token):

            async def send_with_cookie(message: Message) -> None:
                if message["type"] == "http.response.start":
                    value = f"{COOKIE}={token}; Path=/; HttpOnly; SameSite=Strict"
                    message["headers"] = [
                        *message.get("headers", []),
                        (b"set-cookie", value.encode("latin-1")),
                    ]
                await send(message)

            await self.app(scope, receive, send_with_cookie)
            return
        response = PlainTextResponse(
            "401 a token is required: send 'Authorization: Bearer <token>' "
            "or open the page with ?token=<token>\n",
            status_code=401,
            headers={"WWW-Authenticate": "Bearer"},
        )
        await response(scope, receive, send)
