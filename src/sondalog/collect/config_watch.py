"""A logger source's configuration, watched at its contacts (issue 22; docs/collector.md
"Configuration history").

At a contact (every one by default; ``config_every = N``: every N-th) the source's logger is
read whole: every setting of §6.1 that a station file holds, as ``logger config pull`` reads
it, in few full lines (:func:`~sondalog.client.station_read.read_config`, issue 24: 2.10's 841
settings in 80 lines and one round trip, the identity first; 1.16's 283 in 22). When
the raw answers are the ones recorded at this source's last check (their digest), nothing
changed and nothing is parsed, hashed or written: the contact's summary says "configuration
unchanged" (with the drift said then). Otherwise the answers are parsed, and their
:func:`config_hash` (SHA-256 of a canonical form) is compared with the last one stored for
the source's logger; a different one stores a ``config_history`` row with the diff
(:func:`diff_lines`) and writes a ``config`` event (the dashboard's log). The first contact
(of a logger, or of this process) stores the configuration as it is, without a diff, or
finds it as stored.

With ``expect = "station.toml"`` the configuration is also compared with that station file,
as ``logger config plan`` compares it (:func:`drift_lines`): the number of settings that
differ is the source's ``drift`` (``config_state``; a ``health`` alarm with ``measure =
"drift"`` raises on it and clears when it is 0 again), and a ``config`` event says when the
logger starts to drift, when its drift changes and when it matches again. Conversion tables
(§10) are not compared: reading them is an XMODEM transfer (§6.16), too much for a contact;
their names in the channels' settings are.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Mapping

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ClientError
from sondalog.client.station_apply import Refused, fit
from sondalog.client.station_file import Station
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_logger import desired_values, plan
from sondalog.client.station_read import read_config
from sondalog.client.station_schema import instances
from sondalog.collect import config_history as history
from sondalog.collect.config import SourceConfig
from sondalog.collect.store_sqlite import SqliteStore, now_text

log = logging.getLogger(__name__)
#: Lines of a diff an event holds at most (the history row holds all of it).
MAX_EVENT_LINES = 40
#: Hex digits of a hash shown in texts.
SHORT = 12


def config_hash(values: Mapping[str, str], protocol: str) -> str:
    """SHA-256 (hex) of the canonical form: JSON of the protocol version and every setting
    (name -> value as read back), keys sorted, no blanks."""
    form = json.dumps(
        {"protocol": protocol, "settings": dict(values)},
        ensure_ascii=False,
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(form.encode()).hexdigest()


def diff_lines(old: Mapping[str, str], new: Mapping[str, str], protocol: str) -> list[str]:
    """``channel 3 sampling period: 000500 -> 000100``, one line per setting that differs,
    in the order of a station file (the manual's); as ``logger config plan`` prints them."""
    out: list[str] = []
    for setting, n in instances(LIMITS[protocol]):
        name = setting.name(n)
        was, now = old.get(name), new.get(name)
        if was != now:
            out.append(f"{name}: {was or '(empty)'} -> {now or '(empty)'}")
    return out


def drift_lines(
    station: Station, values: Mapping[str, str], protocol: str, serial: str
) -> list[str]:
    """What ``logger config plan`` would write to make the logger as ``station`` says (one
    line per setting, its ``describe``), or why the file cannot be applied; [] when the
    logger matches the file."""
    if station.serial_number and station.serial_number != serial:
        return [f"the file is for logger {station.serial_number}; this is logger {serial}"]
    try:
        fit(station, protocol)
    except Refused as exc:
        return list(exc.problems)
    given = {name: value for name, value in station.values.items() if name in values}
    desired = desired_values(given, protocol, serial)
    return [change.describe() for change in plan(values, desired, protocol)]


def _bounded(lines: list[str]) -> str:
    shown = lines[:MAX_EVENT_LINES]
    if len(lines) > MAX_EVENT_LINES:
        shown.append(f"... and {len(lines) - MAX_EVENT_LINES} more (config_history)")
    return "\n".join(shown)


def _count(n: int) -> str:
    return f"{n} setting{'s' if n != 1 else ''}"


class ConfigWatch:
    """The configuration check of one logger source (see the module doc)."""

    def __init__(self, config: SourceConfig, store: SqliteStore) -> None:
        self.config = config
        self.store = store
        self._contacts = 0
        self._version: str | None = None  # the logger's protocol version at the last check
        #: The digest of the raw answers last recorded, and what the summary said then.
        self._seen: tuple[bytes, str] | None = None

    async def check(self, client: Ala1Client) -> str | None:
        """Read and record the configuration over ``client``'s open line (in a contact,
        before the download); a few words for the contact's summary, or None when not
        checked. A logger that does not answer the reads leaves an event and does not fail
        the contact."""
        every = self.config.config_every
        self._contacts += 1
        if every == 0 or (self._contacts - 1) % every:
            return None
        try:
            read = await read_config(client, self._version)
            self._version = read.version
            if self._seen is not None and self._seen[0] == read.digest:
                return self._seen[1]  # the same answers as last time: nothing to do
            values = read.values()
        except ClientError as exc:
            self._version = None  # the next check identifies the logger first (whatever it is)
            text = f"configuration not read: {exc}"
            log.warning("source %s: %s", self.config.name, text)
            self.store.event(self.config.name, "config", text)
            return text
        said, drift = self._record(read.serial, read.version, values)
        self._seen = (read.digest, "configuration unchanged" + drift)
        return said + drift

    def note(self, serial: str, protocol: str, values: dict[str, str]) -> str:
        """Record the configuration ``values`` of logger ``serial`` read now; in one
        transaction: the history row, the state, the events."""
        said, drift = self._record(serial, protocol, values)
        return said + drift

    def _record(self, serial: str, protocol: str, values: dict[str, str]) -> tuple[str, str]:
        """:meth:`note`: the summary, and what it says of the drift (", as station.toml")."""
        name, db = self.config.name, self.store.db
        now = now_text()
        digest = config_hash(values, protocol)
        drift = ""
        with db:
            stored = history.last_hash(db, name, serial)
            if stored != digest:
                known = None if stored is None else history.last(db, name, serial)
                diff = [] if known is None else diff_lines(known.values, values, protocol)
                history.record(
                    db,
                    source=name,
                    logger=serial,
                    time=now,
                    protocol=protocol,
                    old_hash=stored,
                    new_hash=digest,
                    diff=diff,
                    values=values,
                )
                self._event(now, known, digest, diff)
            if stored == digest:
                said = "configuration unchanged"
            elif stored is not None:
                said = "configuration changed"
            else:
                said = f"configuration read: {digest[:SHORT]}"
            history.set_state(db, name, logger=serial, hash=digest, checked=now)
            if self.config.expect is not None:
                drift = self._drift(now, drift_lines(self.config.expect, values, protocol, serial))
        return said, drift

    def _event(self, now: str, known: history.Known | None, digest: str, diff: list[str]) -> None:
        """A change is an event (the dashboard's log); the first read is a history row only
        (and the contact's summary): it changes nothing."""
        if known is None:
            return
        text = (
            f"configuration changed: {known.hash[:SHORT]} -> {digest[:SHORT]}, "
            f"{_count(len(diff))}\n{_bounded(diff)}"
        )
        log.info("source %s: %s", self.config.name, text.replace("\n", "; "))
        self._write_event(now, text)

    def _write_event(self, now: str, text: str) -> None:
        self.store.db.execute(
            "INSERT INTO events (time, source, kind, text) VALUES (?, ?, 'config', ?)",
            (now, self.config.name, text),
        )

    def _drift(self, now: str, lines: list[str]) -> str:
        """The drift from the ``expect`` file: state, and an event when it changes."""
        name, db = self.config.name, self.store.db
        path = self.config.expect_path or "the expected file"
        before = history.state(db, name) or {}
        text = "\n".join(lines)
        history.set_state(db, name, expect=path, drift=len(lines), drift_text=text)
        if lines and before.get("drift_text") != text:
            event = f"configuration drifts from {path}: {_count(len(lines))}\n{_bounded(lines)}"
            log.warning("source %s: %s", name, event.replace("\n", "; "))
            self._write_event(now, event)
        elif not lines and before.get("drift"):
            self._write_event(now, f"configuration matches {path} again")
            log.info("source %s: configuration matches %s again", name, path)
        return f", drifts from {path} ({_count(len(lines))})" if lines else f", as {path}"
