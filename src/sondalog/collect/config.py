"""The collector's configuration file (TOML), checked with file, line and field in errors.

::

    [sqlite]                    # the store (default: collector.sqlite beside this file)
    path = "collector.sqlite"
    readings = true             # false: keep only sources, cursors and events here

    [buffer]                    # where batches wait while a sink is down
    path = "collector.buffer.sqlite"

    [collect]                   # optional: defaults of every source
    keep_open = false           # the default of the tcp:// loggers' keep_open

    [[source]]                  # a logger, downloaded incrementally
    url = "tcp://127.0.0.1:10001"
    interval = 60               # seconds between contacts
    name = "station-1"          # optional (default: the URL)
    timezone = "Europe/Prague"  # optional: fills the utc column
    timeout = 5                 # optional: seconds to wait for an answer
    retry = 5                   # optional: first retry after a failure, doubling ...
    retry_max = 600             # ... up to this many seconds
    config_every = 1            # optional: read its configuration every N contacts (0: never)
    expect = "station.toml"     # optional: the station file it should match (config_expect.py)
    keep_open = false           # optional: true keeps the TCP connection between contacts
                                # (a server that takes several connections; keep_open.py)

    [[source]]                  # HCTMPS1 modules on a bus, polled
    kind = "bus"
    url = "tcp://127.0.0.1:10002"
    modules = ["T1", "H1"]      # optional (default: scan the bus)
    units = { T1 = "°C", H1 = "%" }
    interval = 10

    [[source]]                  # loggers' data messages by e-mail (docs/collector.md)
    kind = "mailbox"
    url = "pop3://user@example.net:secret@127.0.0.1:1110"
    logger = "000001"           # optional: whose rows, when the message does not say
    loggers = { "logger@example.net" = "000001" }   # optional: sender or i name -> snumber
    keep = false                # optional: true leaves the mails in the mailbox
    signal = 3                  # optional: the channels with GSM signal and credit (types
    credit = 4                  # 12, 11) when no download told the store
    channels = { 1 = "Air [C]", 2 = "Signal" }   # optional: names and units, likewise

    [[source]]                  # loggers' data messages by SMS, from the GSM network's API
    kind = "network"
    url = "http://127.0.0.1:8025"
    number = "+420700000001"    # the phone the loggers text

    [web]                       # the dashboard (default: on, 127.0.0.1:8080)
    listen = "127.0.0.1:8080"   # beyond loopback: allow_remote = true and a token

    [cluster]                   # optional: share the sources with the other collectors
    lease = 30                  # that use the same [postgres] server (docs/scaling.md)

    [postgres]                  # optional sinks (docs/collector-sinks.md): a table of
    dsn = "postgresql://..."    # every sink registered in sondalog.collect.sinks, checked
    [mqtt]                      # by the sink's own parse when the file is loaded
    url = "mqtt://127.0.0.1:1883"

Relative paths are relative to the configuration file's directory. Every table is read
through :class:`sondalog.config.Table`: an unknown table or key is refused with a "did you
mean", every error is ``FILE:LINE: field: message``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from sondalog.client import parse_url
from sondalog.client.bus_links import BusUrlError, parse_bus_url
from sondalog.client.endpoints import TcpEndpoint
from sondalog.client.station_file import Station
from sondalog.collect.alarms import AlarmPlan, parse_alarms
from sondalog.collect.alarms.senders import find_sender
from sondalog.collect.config_expect import read_expect
from sondalog.collect.leases import default_lease
from sondalog.collect.message_url import check_message_url
from sondalog.collect.sinks import SinkError, find_sink, known_names
from sondalog.collect.store_sqlite import parse_store
from sondalog.collect.web_config import WebConfig, parse_web
from sondalog.config import Table, load

#: The collector's own tables; any other top-level table is a sink's (``sinks.find_sink``).
OWN_TABLES = ("sqlite", "buffer", "collect", "source", "web", "alarm", "notify", "cluster")
_SOURCE = (
    "url",
    "interval",
    "name",
    "kind",
    "timezone",
    "timeout",
    "retry",
    "retry_max",
    "modules",
    "units",
    "logger",
    "loggers",
    "number",
    "keep",
    "signal",
    "credit",
    "channels",
    "expect",
    "config_every",
    "keep_open",
)
KINDS = ("logger", "bus", "mailbox", "network")
#: Sources whose rows come in loggers' data messages (docs/collector.md).
MESSAGE_KINDS = ("mailbox", "network")
#: Keys only the message sources (``mailbox``, ``network``) take.
_MESSAGE_KEYS = ("logger", "loggers", "number", "keep", "signal", "credit", "channels")
#: A string with something other than blanks in it.
_NOT_BLANK = r"(?s).*\S.*"
_SECONDS = "a positive number of seconds"


@dataclass(frozen=True, slots=True)
class SourceConfig:
    name: str
    url: str
    kind: str = "logger"
    interval: float = 60.0
    zone: ZoneInfo | None = None
    timeout: float = 5.0
    retry: float = 5.0
    retry_max: float = 600.0
    modules: tuple[str, ...] = ()
    units: dict[str, str] = field(default_factory=dict)
    logger: str | None = None
    loggers: dict[str, str] = field(default_factory=dict)
    number: str | None = None
    keep: bool = False
    #: Channel numbers of the GSM signal (type 12) and credit (type 11) in the rows of a
    #: message source, when no download told the store the channels' types.
    signal: int | None = None
    credit: int | None = None
    #: Channel number -> ``"Name [unit]"`` of the loggers of a message source, when no
    #: download told the store their names and units.
    channels: dict[int, str] = field(default_factory=dict)
    #: A logger's configuration: read every this many contacts (0: never; config_watch.py),
    #: and the station file it should match (``expect``, with its path).
    config_every: int = 1
    expect: Station | None = None
    expect_path: str | None = None
    #: A ``tcp://`` logger's connection is kept between contacts (:mod:`keep_open`).
    keep_open: bool = False


@dataclass(frozen=True, slots=True)
class ClusterConfig:
    """``[cluster]``: this collector shares its sources with the others on the
    ``[postgres]`` server (:mod:`sondalog.collect.share`)."""

    #: Seconds a source stays with a member that stopped renewing (turns: a third of it).
    lease: float


@dataclass(frozen=True, slots=True)
class CollectorConfig:
    path: Path
    store: Path
    keep_readings: bool
    buffer: Path
    sources: tuple[SourceConfig, ...]
    #: Sink name -> the configuration its registration's ``parse`` made of its table.
    sinks: dict[str, Any]
    web: WebConfig = field(default_factory=WebConfig)
    #: ``[[alarm]]`` rules and ``[[notify]]`` destinations (docs/alarms.md).
    alarms: AlarmPlan = field(default_factory=AlarmPlan)
    #: ``[cluster]``, None: this collector polls every source itself.
    cluster: ClusterConfig | None = None


def load_config(path: Path) -> CollectorConfig:
    """Read and check ``path`` (a regular UTF-8 file, size-limited, finite numbers: see
    :func:`sondalog.config.load`); raises :class:`ConfigError`."""
    return parse_config(load(path))


def parse_config(root: Table) -> CollectorConfig:
    """The collector's configuration from the root table of its file."""
    path = root.file
    if path is None:
        raise root.fail(None, "a collector's configuration is a file")
    root.keys({*OWN_TABLES, *known_names()})
    sinks = {name: _sink(root, name) for name in root if name not in OWN_TABLES}
    store = parse_store(root.table("sqlite"))
    default_buffer = store.path.with_name(store.path.stem + ".buffer.sqlite")
    buffer_table = root.table("buffer", keys=("path",))
    buffer = buffer_table.path("path", default_buffer)
    if buffer.is_dir():
        raise buffer_table.fail("path", f"{buffer} is a directory; name the buffer's file")
    tables = root.tables("source", keys=_SOURCE)
    if not tables:
        raise root.fail("source", "no [[source]] table: nothing to collect")
    defaults = root.table("collect", keys=("keep_open",))
    keep_open = defaults.flag("keep_open", False)
    sources = [_source(t, keep_open) for t in tables]
    seen: set[str] = set()
    for table, source in zip(tables, sources, strict=True):
        if source.name in seen:
            raise table.fail("name", f"{source.name!r} is used by another source")
        seen.add(source.name)
    web = parse_web(root.table("web"), os.environ)
    alarms = _alarms(root)
    cluster = _cluster(root, sources, sinks)
    return CollectorConfig(
        path, store.path, store.readings, buffer, tuple(sources), sinks, web, alarms, cluster
    )


def _cluster(
    root: Table, sources: list[SourceConfig], sinks: dict[str, Any]
) -> ClusterConfig | None:
    """``[cluster]`` (``share = false`` turns it off), which needs ``[postgres]``."""
    table = root.table("cluster", keys=("share", "lease"))
    if "cluster" not in root or not table.flag("share", True):
        return None
    if "postgres" not in sinks:
        raise root.fail(
            "cluster", "sharing the sources needs a [postgres] table: the leases live there"
        )
    lease = default_lease(s.interval for s in sources)
    return ClusterConfig(table.number("lease", lease, lo=0.3, hi=3600, what=_LEASE))


_LEASE = "a number of seconds from 0.3 to 3600"


def _alarms(root: Table) -> AlarmPlan:
    """``[[alarm]]`` and ``[[notify]]``; a destination kind without a registered sender is
    refused now (its module is imported, nothing connects)."""
    plan = parse_alarms(root)
    for i, notify in enumerate(plan.notify.values()):
        if find_sender(notify.kind) is None:
            raise root.source.fail(
                f"notify[{i}].kind",
                f"no sender for notifications of kind {notify.kind!r} is installed",
            )
    return plan


def _sink(root: Table, name: str) -> Any:
    """The sink table ``[name]`` parsed by its registration (imported if built in)."""
    try:
        kind = find_sink(name)
    except SinkError as exc:
        raise root.fail(name, str(exc)) from None
    if kind is None:  # known_names() lists every name find_sink knows
        raise root.fail(name, "no sink registered under this name")
    return kind.parse(root.table(name))


def _seconds(t: Table, key: str, default: float) -> float:
    return t.number(key, default, above=0, what=_SECONDS)


def _zone(name: str) -> ZoneInfo:
    try:
        return ZoneInfo(name)
    except (ZoneInfoNotFoundError, ValueError):
        raise ValueError(f"unknown time zone {name!r}") from None


def _check_url(kind: str, url: str) -> str:
    """``url`` if a ``kind`` source can read it (``ValueError`` says why not)."""
    try:
        if kind == "logger":
            parse_url(url)
        elif kind == "bus":
            parse_bus_url(url)
        else:
            check_message_url(kind, url)
    except BusUrlError as exc:
        raise ValueError(str(exc)) from None
    return url


def _source(t: Table, keep_open: bool = False) -> SourceConfig:
    if "url" not in t:
        raise t.fail("url", "required: the logger's or the bus's URL")
    kind = t.text("kind", "logger", choices=KINDS)
    url = t.convert("url", lambda url: _check_url(kind, url))
    message = _message_keys(t, kind)
    name = t.text("name", url, pattern=_NOT_BLANK, what="a non-empty string")
    zone = t.convert("timezone", _zone, None)
    if kind != "bus" and ("modules" in t or "units" in t):
        raise t.fail("modules", "only a bus source has modules and units")
    modules = t.texts("modules", ())
    if not all(modules):
        raise t.fail("modules", "must be a list of module IDs")
    retry = _seconds(t, "retry", 5.0)
    watch = _watch_keys(t, kind, url)
    return SourceConfig(
        name=name,
        url=url,
        kind=kind,
        interval=_seconds(t, "interval", 60.0),
        zone=zone,
        timeout=_seconds(t, "timeout", 5.0),
        retry=retry,
        retry_max=max(retry, _seconds(t, "retry_max", 600.0)),
        modules=tuple(modules),
        units=t.text_map("units"),
        keep_open=_keep_open(t, kind, url, keep_open),
        **message,
        **watch,
    )


def _keep_open(t: Table, kind: str, url: str, default: bool) -> bool:
    """``keep_open``: only a logger's ``tcp://`` connection is kept between contacts (a
    serial line, a data call and a bus are connected for each contact); ``default`` (the
    ``[collect]`` table's) applies to the sources that can keep theirs."""
    if "keep_open" not in t:
        return default and kind == "logger" and isinstance(parse_url(url), TcpEndpoint)
    keep = t.flag("keep_open")
    if keep and kind != "logger":
        raise t.fail("keep_open", "only a logger source keeps its connection open")
    if keep and not isinstance(parse_url(url), TcpEndpoint):
        raise t.fail("keep_open", "only a tcp:// connection is kept open")
    return keep


def _watch_keys(t: Table, kind: str, url: str) -> dict[str, Any]:
    """``config_every`` and ``expect`` of a logger source (docs/collector.md)."""
    if kind != "logger":
        for key in ("expect", "config_every"):
            if key in t:
                raise t.fail(key, "only a logger source has its configuration read")
        return {}
    every = t.integer("config_every", 1, lo=0, what="a count of contacts (0: never)")
    if every == 0 and "expect" in t:
        raise t.fail("config_every", "0 never reads the configuration: expect needs it read")
    expect = read_expect(t, url)
    if expect is None:
        return {"config_every": every}
    return {"config_every": every, "expect": expect[0], "expect_path": str(expect[1])}


def _message_keys(t: Table, kind: str) -> dict[str, Any]:
    """``logger``, ``loggers``, ``number``, ``keep``, ... of a message source, checked."""
    if kind not in MESSAGE_KINDS:
        for key in _MESSAGE_KEYS:
            if key in t:
                raise t.fail(key, "only a mailbox or network source has it")
        return {}
    loggers = t.text_map("loggers")
    if not all(loggers.values()):
        raise t.fail("loggers", 'must be a table of sender or i name = "i snumber"')
    if kind == "mailbox" and "number" in t:
        raise t.fail("number", "only a network source has a number")
    if kind == "network" and "number" not in t:
        raise t.fail("number", "required: the phone number whose SMS to read")
    keep = t.flag("keep", False)
    if keep and kind == "network":
        raise t.fail("keep", "only a mailbox source keeps its messages")
    channel = "the number of the logger's channel"
    return {
        "logger": t.opt_text("logger", pattern=_NOT_BLANK, what="the logger's i snumber"),
        "loggers": loggers,
        "number": t.opt_text("number", pattern=_NOT_BLANK, what="a phone number"),
        "keep": keep,
        "signal": t.opt_integer("signal", lo=1, what=channel),
        "credit": t.opt_integer("credit", lo=1, what=channel),
        "channels": _channel_names(t),
    }


def _channel_names(t: Table) -> dict[int, str]:
    """``{ 1 = "Air [C]", ... }``: channel number -> name with its unit in brackets."""
    shape = 'a table of channel number = "Name [unit]", like { 1 = "Air [C]" }'
    if "channels" in t and not t.is_table("channels"):
        raise t.fail("channels", f"must be {shape}")
    table = t.table("channels")
    out: dict[int, str] = {}
    for key in table:
        if not key.isdecimal() or int(key) < 1:  # isdigit would let "²" through
            raise table.fail(key, f"not a channel number; must be {shape}")
        out[int(key)] = table.text(key, pattern=_NOT_BLANK, what=f"a name; {shape}").strip()
    return out
