"""The collector's ``[web]`` table: where it serves the dashboard (docs/collector.md).

::

    [web]
    listen = "127.0.0.1:8080"   # the default; port 0 takes any free port
    allow_remote = false        # true: allow an address beyond loopback ...
    token = "..."               # ... and then a token is required (or $SONDALOG_WEB_TOKEN)
    enabled = true              # false: no dashboard
    readings = "auto"           # where it reads the readings: "sqlite", "postgres", "auto"

Without a ``[web]`` table the collector serves the dashboard on ``127.0.0.1:8080``. An address
beyond loopback is refused here, at configuration time, unless ``allow_remote = true`` and a
token is set: the same rule as :func:`sondalog.web.server.check_listen`, checked early so that
``sondalog collect --check`` reports it with the file's line.

``readings`` says which store of record the dashboard reads the readings from (issue 24,
docs/decisions.md): ``sqlite`` the collector's file, ``postgres`` the server of the
``[postgres]`` sink, ``auto`` (the default) the file unless it keeps no readings
(``[sqlite] readings = false``) and a ``[postgres]`` sink is configured. Sources, events,
channel types always come from the file (only it has them). ``blocks``, the switch of the
per-block extremes while they cost ingest twice its time, is gone: the sinks keep them per
batch now (:mod:`sondalog.collect.blocks_sql`); ``blocks = true`` is still accepted, and
``blocks = false`` is refused with that reason.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from sondalog.config import Table, format_address, is_loopback

DEFAULT_LISTEN = ("127.0.0.1", 8080)
#: The environment variable a token may come from (kept out of the file and the command line).
TOKEN_ENV = "SONDALOG_WEB_TOKEN"
_KEYS = ("allow_remote", "blocks", "enabled", "listen", "readings", "token")
#: Where the dashboard may read the readings from.
READINGS = ("auto", "sqlite", "postgres")
_TOKEN = r"[A-Za-z0-9._~+/=-]{8,}"
_TOKEN_WHAT = "8 or more characters of letters, digits and ._~+/=-"


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
    #: The store of record the dashboard reads the readings from (:data:`READINGS`).
    readings: str = "auto"


def parse_web(table: Table, env: Mapping[str, str]) -> WebConfig:
    """Check the ``[web]`` table (``ConfigError`` names the file, line and field); the token
    may come from ``env``'s :data:`TOKEN_ENV`."""
    table.keys(_KEYS)
    enabled = table.flag("enabled", True)
    remote = table.flag("allow_remote", False)
    host, port = table.address("listen", format_address(*DEFAULT_LISTEN))
    # The pattern is checked here, not by ``text(pattern=...)``: a refused token is not echoed.
    token = (
        table.text("token", what=_TOKEN_WHAT) if "token" in table else env.get(TOKEN_ENV) or None
    )
    if token is not None and not re.fullmatch(_TOKEN, token):
        source = "" if "token" in table else f"${TOKEN_ENV}: "
        raise table.fail("token", f"{source}must be {_TOKEN_WHAT}")
    if enabled and not is_loopback(host):
        if not remote:
            raise table.fail(
                "listen",
                f"refusing to serve the dashboard on {host}: only loopback (127.0.0.1) unless "
                "allow_remote = true and a token is set",
            )
        if token is None:
            raise table.fail(
                "token",
                f"refusing to serve the dashboard on {host} without a token: set token "
                f"(or ${TOKEN_ENV}); requests then need 'Authorization: Bearer <token>'",
            )
    readings = table.text("readings", "auto", choices=READINGS)
    if not table.flag("blocks", True):
        raise table.fail(
            "blocks",
            "the per-block extremes are always kept now (issue 24: they cost each batch "
            "little); remove the line",
        )
    return WebConfig(enabled, host, port, remote, token, "listen" in table, readings)


def readings_on_server(web: WebConfig, *, file_keeps_readings: bool, has_postgres: bool) -> bool:
    """Whether the dashboard reads the readings from the ``[postgres]`` server (else the
    collector's file), by ``[web] readings``; ``postgres`` without a ``[postgres]`` sink is
    a ``ValueError`` (the caller names the field)."""
    if web.readings == "postgres":
        if not has_postgres:
            raise ValueError("readings = 'postgres' needs a [postgres] sink")
        return True
    if web.readings == "sqlite":
        return False
    return has_postgres and not file_keeps_readings
