"""The collector's configuration file (TOML), checked with file, line and field in errors.

::

    [sqlite]                    # the store (default: collector.sqlite beside this file)
    path = "collector.sqlite"
    readings = true             # false: keep only sources, cursors and events here

    [buffer]                    # where batches wait while a sink is down
    path = "collector.buffer.sqlite"

    [[source]]                  # a logger, downloaded incrementally
    url = "tcp://127.0.0.1:10001"
    interval = 60               # seconds between contacts
    name = "station-1"          # optional (default: the URL)
    timezone = "Europe/Prague"  # optional: fills the utc column
    timeout = 5                 # optional: seconds to wait for an answer
    retry = 5                   # optional: first retry after a failure, doubling ...
    retry_max = 600             # ... up to this many seconds

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

    [postgres]                  # optional sinks (docs/collector-sinks.md): a table of
    dsn = "postgresql://..."    # every sink registered in sondalog.collect.sinks, checked
    [mqtt]                      # by the sink's own parse when the file is loaded
    url = "mqtt://127.0.0.1:1883"

Relative paths are relative to the configuration file's directory.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from sondalog.client import parse_url
from sondalog.client.bus_links import BusUrlError, parse_bus_url
from sondalog.collect.message_url import check_message_url
from sondalog.collect.sinks import SinkError, SinkKind, find_sink, known_names
from sondalog.collect.web_config import WebConfig, parse_web
from sondalog.config import ConfigError, locate, read_site_file

#: The collector's own tables; any other top-level table is a sink's (``sinks.find_sink``).
_TOP = {"sqlite", "buffer", "source", "web"}
_SOURCE = {
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
}
KINDS = ("logger", "bus", "mailbox", "network")
#: Keys only the message sources (``mailbox``, ``network``) take.
_MESSAGE_KEYS = ("logger", "loggers", "number", "keep", "signal", "credit", "channels")


#: ``fail(field, message)``: the :class:`ConfigError` to raise, with the field's line.
Fail = Callable[[str, str], ConfigError]


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


@dataclass(frozen=True, slots=True)
class CollectorConfig:
    path: Path
    store: Path
    keep_readings: bool
    buffer: Path
    sources: tuple[SourceConfig, ...]
    #: Sink name -> the configuration its registration's ``parse`` made of its table.
    sinks: dict[str, Any]
    sink_lines: dict[str, int | None] = field(default_factory=dict)
    web: WebConfig = field(default_factory=WebConfig)

    def sink_error(self, name: str, exc: Exception) -> ConfigError:
        """A sink factory's complaint about its table, with the table's line."""
        text = str(exc).removeprefix(f"{name}: ").removeprefix(f"{name}.")
        return ConfigError(self.path, name, text, self.sink_lines.get(name))


def load_config(path: Path) -> CollectorConfig:
    """Read and check ``path``; raises :class:`ConfigError`."""
    try:
        data, text = read_site_file(path)  # a regular UTF-8 file, size-limited, finite numbers
    except ConfigError as exc:
        raise ConfigError(path, exc.field, exc.message, exc.line) from None
    return parse_config(data, path, text)


def parse_config(data: Mapping[str, Any], path: Path, text: str | None = None) -> CollectorConfig:
    def fail(where: str, message: str) -> ConfigError:
        return ConfigError(path, where, message, locate(text, where))

    kinds = {key: _sink_kind(key, fail) for key in data if key not in _TOP}
    base = path.parent

    def table(name: str) -> dict[str, Any]:
        value = data.get(name, {})
        if not isinstance(value, dict):
            raise fail(name, "must be a table")
        return value

    sqlite = table("sqlite")
    for key in sqlite:
        if key not in ("path", "readings"):
            raise fail(f"sqlite.{key}", "unknown key (known: path, readings)")
    store = _path(sqlite.get("path", "collector.sqlite"), base, "sqlite.path", fail, "store's")
    keep = sqlite.get("readings", True)
    if not isinstance(keep, bool):
        raise fail("sqlite.readings", "must be true or false")
    buffer_table = table("buffer")
    for key in buffer_table:
        if key != "path":
            raise fail(f"buffer.{key}", "unknown key (known: path)")
    default_buffer = store.with_name(store.stem + ".buffer.sqlite")
    buffer = _path(
        buffer_table.get("path", str(default_buffer)), base, "buffer.path", fail, "buffer's"
    )

    raw_sources = data.get("source", [])
    if not isinstance(raw_sources, list) or not all(isinstance(s, dict) for s in raw_sources):
        raise fail("source", "must be [[source]] tables")
    if not raw_sources:
        raise fail("source", "no [[source]] table: nothing to collect")
    sources = [_source(s, f"source[{i}]", fail) for i, s in enumerate(raw_sources)]
    seen: set[str] = set()
    for i, source in enumerate(sources):
        if source.name in seen:
            raise fail(f"source[{i}].name", f"{source.name!r} is used by another source")
        seen.add(source.name)
    sinks = {name: _sink(kind, table(name), fail) for name, kind in kinds.items()}
    lines = {name: locate(text, name) for name in sinks}
    web = parse_web(table("web"), fail, os.environ)
    return CollectorConfig(path, store, keep, buffer, tuple(sources), sinks, lines, web)


def _sink_kind(name: str, fail: Fail) -> SinkKind[Any]:
    """The sink registered for the top-level table ``name``; an unknown table is refused."""
    try:
        kind = find_sink(name)
    except SinkError as exc:
        raise fail(name, str(exc)) from None
    if kind is None:
        raise fail(name, f"unknown table (known: {', '.join(sorted({*_TOP, *known_names()}))})")
    return kind


def _sink(kind: SinkKind[Any], table: dict[str, Any], fail: Fail) -> Any:
    """The sink's table parsed by its registration (``report`` -> ``FILE:LINE: NAME.KEY``)."""
    name = kind.table

    def report(key: str, message: str) -> ConfigError:
        text = message.removeprefix(f"{name}: ").removeprefix(f"{name}.")
        if key:
            return fail(f"{name}.{key}", text)
        return fail(name, text)

    try:
        return kind.parse(table, report)
    except ConfigError:
        raise
    except ValueError as exc:  # a parse that raised instead of reporting
        raise report("", str(exc)) from None


def _path(value: object, base: Path, where: str, fail: Any, what: str) -> Path:
    """A file the collector writes (``what``: whose): a name, not a directory."""
    if not isinstance(value, str) or not value:
        raise fail(where, "must be a file name")
    path = base / Path(value).expanduser()
    if path.is_dir():
        raise fail(where, f"{path} is a directory; name the {what} file")
    return path


def _number(table: Mapping[str, Any], key: str, default: float, where: str, fail: Any) -> float:
    value = table.get(key, default)
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise fail(f"{where}.{key}", "must be a positive number of seconds")
    return float(value)


def _source(s: Mapping[str, Any], where: str, fail: Any) -> SourceConfig:
    for key in s:
        if key not in _SOURCE:
            raise fail(f"{where}.{key}", f"unknown key (known: {', '.join(sorted(_SOURCE))})")
    url = s.get("url")
    if not isinstance(url, str) or not url:
        raise fail(f"{where}.url", "required: the logger's or the bus's URL")
    kind = s.get("kind", "logger")
    if kind not in KINDS:
        raise fail(f"{where}.kind", f"must be one of {', '.join(KINDS)}")
    try:
        if kind == "logger":
            parse_url(url)
        elif kind == "bus":
            parse_bus_url(url)
        else:
            check_message_url(kind, url)
    except (ValueError, BusUrlError) as exc:
        raise fail(f"{where}.url", str(exc)) from None
    message = _message_keys(s, kind, where, fail)
    name = s.get("name", url)
    if not isinstance(name, str) or not name.strip():
        raise fail(f"{where}.name", "must be a non-empty string")
    zone = None
    if "timezone" in s:
        try:
            zone = ZoneInfo(str(s["timezone"]))
        except (ZoneInfoNotFoundError, ValueError):
            raise fail(f"{where}.timezone", f"unknown time zone {s['timezone']!r}") from None
    modules = s.get("modules", [])
    if kind != "bus" and ("modules" in s or "units" in s):
        raise fail(f"{where}.modules", "only a bus source has modules and units")
    if not isinstance(modules, list) or not all(isinstance(m, str) and m for m in modules):
        raise fail(f"{where}.modules", "must be a list of module IDs")
    units = s.get("units", {})
    if not isinstance(units, dict) or not all(isinstance(v, str) for v in units.values()):
        raise fail(f"{where}.units", 'must be a table of module ID = "unit"')
    retry = _number(s, "retry", 5.0, where, fail)
    return SourceConfig(
        name=name,
        url=url,
        kind=kind,
        interval=_number(s, "interval", 60.0, where, fail),
        zone=zone,
        timeout=_number(s, "timeout", 5.0, where, fail),
        retry=retry,
        retry_max=max(retry, _number(s, "retry_max", 600.0, where, fail)),
        modules=tuple(modules),
        units=dict(units),
        **message,
    )


def _message_keys(s: Mapping[str, Any], kind: str, where: str, fail: Any) -> dict[str, Any]:
    """``logger``, ``loggers``, ``number``, ``keep`` of a message source, checked."""
    if kind not in ("mailbox", "network"):
        for key in _MESSAGE_KEYS:
            if key in s:
                raise fail(f"{where}.{key}", "only a mailbox or network source has it")
        return {}
    logger = s.get("logger")
    if logger is not None and (not isinstance(logger, str) or not logger.strip()):
        raise fail(f"{where}.logger", "must be the logger's i snumber")
    loggers = s.get("loggers", {})
    if not isinstance(loggers, dict) or not all(isinstance(v, str) and v for v in loggers.values()):
        raise fail(f"{where}.loggers", 'must be a table of sender or i name = "i snumber"')
    number = s.get("number")
    if kind == "network" and (not isinstance(number, str) or not number.strip()):
        raise fail(f"{where}.number", "required: the phone number whose SMS to read")
    if kind == "mailbox" and number is not None:
        raise fail(f"{where}.number", "only a network source has a number")
    keep = s.get("keep", False)
    if not isinstance(keep, bool) or (keep and kind == "network"):
        raise fail(f"{where}.keep", "a mailbox source's keep is true or false")
    gsm: dict[str, int | None] = {}
    for key in ("signal", "credit"):
        value = s.get(key)
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, int) or value < 1
        ):
            raise fail(f"{where}.{key}", "must be the number of the logger's channel")
        gsm[key] = value
    channels = _channel_names(s.get("channels", {}), f"{where}.channels", fail)
    return {
        "logger": logger,
        "loggers": dict(loggers),
        "number": number,
        "keep": keep,
        "channels": channels,
        **gsm,
    }


def _channel_names(value: object, where: str, fail: Any) -> dict[int, str]:
    """``{ 1 = "Air [C]", ... }``: channel number -> name with its unit in brackets."""
    shape = 'must be a table of channel number = "Name [unit]", like { 1 = "Air [C]" }'
    if not isinstance(value, dict):
        raise fail(where, shape)
    out: dict[int, str] = {}
    for key, name in value.items():
        if not str(key).isdecimal() or int(key) < 1:  # isdigit would let "²" through
            raise fail(f"{where}.{key}", f"not a channel number; {shape}")
        if not isinstance(name, str) or not name.strip():
            raise fail(f"{where}.{key}", f"must be a name; {shape}")
        out[int(key)] = name.strip()
    return out
