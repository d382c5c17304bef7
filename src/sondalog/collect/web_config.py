"""The collector's ``[web]`` table: where it serves the dashboard (docs/collector.md).

::

    [web]
    listen = "127.0.0.1:8080"   # the default; port 0 takes any free port
    allow_remote = false        # true: allow an address beyond loopback ...
    token = "..."               # ... and then a token is required (or $SONDALOG_WEB_TOKEN)
    enabled = true              # false: no dashboard

Without a ``[web]`` table the collector serves the dashboard on ``127.0.0.1:8080``. An address
beyond loopback is refused here, at configuration time, unless ``allow_remote = true`` and a
token is set: the same rule as :func:`sondalog.web.server.check_listen`, checked early so that
``sondalog collect --check`` reports it with the file's line.
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

DEFAULT_LISTEN = ("127.0.0.1", 8080)
#: The environment variable a token may come from (kept out of the file and the command line).
TOKEN_ENV = "SONDALOG_WEB_TOKEN"
_KEYS = ("allow_remote", "enabled", "listen", "token")
_TOKEN = re.compile(r"[A-Za-z0-9._~+/=-]{8,}")


@dataclass(frozen=True, slots=True)
class WebConfig:
    """Whether and where the collector serves the dashboard."""

    enabled: bool = True
    host: str = DEFAULT_LISTEN[0]
    port: int = DEFAULT_LISTEN[1]
    allow_remote: bool = False
    token: str | None = None
    #: The file names ``listen`` (a busy port is then an error, not a warning).
    explicit: bool = False


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def parse_web(
    table: Mapping[str, Any], fail: Callable[[str, str], Exception], env: Mapping[str, str]
) -> WebConfig:
    """Check ``[web]``; ``fail(field, message)`` makes the error to raise."""
    for key in table:
        if key not in _KEYS:
            raise fail(f"web.{key}", f"unknown key (known: {', '.join(_KEYS)})")
    enabled = table.get("enabled", True)
    remote = table.get("allow_remote", False)
    for key, value in (("enabled", enabled), ("allow_remote", remote)):
        if not isinstance(value, bool):
            raise fail(f"web.{key}", "must be true or false")
    listen = table.get("listen", f"{DEFAULT_LISTEN[0]}:{DEFAULT_LISTEN[1]}")
    host, sep, port = listen.rpartition(":") if isinstance(listen, str) else ("", "", "")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise fail("web.listen", f'must be "HOST:PORT" (port 0..65535), got {listen!r}')
    token = table.get("token", env.get(TOKEN_ENV) or None)
    if token is not None and (not isinstance(token, str) or not _TOKEN.fullmatch(token)):
        raise fail("web.token", "must be 8 or more characters of letters, digits and ._~+/=-")
    if enabled and not is_loopback(host):
        if not remote:
            raise fail(
                "web.listen",
                f"refusing to serve the dashboard on {host}: only loopback (127.0.0.1) unless "
                "allow_remote = true and a token is set",
            )
        if token is None:
            raise fail(
                "web.token",
                f"refusing to serve the dashboard on {host} without a token: set token "
                f"(or ${TOKEN_ENV}); requests then need 'Authorization: Bearer <token>'",
            )
    return WebConfig(enabled, host.strip("[]"), int(port), remote, token, "listen" in table)
