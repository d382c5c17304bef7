"""The ``[[loggers]]`` of a site file: a fleet of virtual loggers in one process (issue 11).

Each entry is one logger, or a numbered range of them::

    [[loggers]]                       # one logger
    serial_number = "A1-0001"
    listen = "127.0.0.1:11001"
    protocol = "2.10"                 # optional; fixed once its state exists
    site = "station.toml"             # optional: the simulated world of that file's [logger]
    backend = "sim"                   # optional, default sim: the hardware backend (registry)

    [[loggers]]                       # a numbered range
    count = 1000
    first = 1                         # optional, default 1
    serial_number = "F{n:04}"         # {n} is the logger's number: F0001 ... F1000
    listen = "127.0.0.1:12000"        # the first's port; logger n listens on port + n - first

A serial number names the logger's state directory (``STATE/loggers/SERIAL``) and its log
lines, so it is made of letters, digits, ``-``, ``_`` and ``.``. Serial numbers are unique
across the file; so are ports, with every other listener of the file (``app.site`` checks them
all; port 0: each logger any free port). Errors name the file, the line
and the field (``loggers[1].listen``), like every site-file error.

A fleet's hardware comes from the backend registry like a single logger's
(:func:`sondalog.app.logger.plan_hardware`): each entry's ``backend`` (default ``sim``) plans
the ``[logger]`` of its ``site`` file once, when the file is loaded; every logger builds its
own hardware from that plan at start. A backend that drives one real board (``linux``: its
registry entry says ``many=False``) cannot serve a fleet and is refused at
``loggers[N].backend``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.app.logger import HardwarePlan, plan_hardware
from sondalog.backends import registry
from sondalog.config import ConfigError, Table, load

#: The most loggers one site file may declare (docs/scaling.md: shard beyond that).
MAX_FLEET = 20_000
_KEYS = ("serial_number", "listen", "protocol", "site", "count", "first", "backend")
_SERIAL = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,31}")


@dataclass(frozen=True)
class FleetLogger:
    """One logger of a fleet: its identity, where it listens, its world."""

    serial_number: str
    listen: tuple[str, int]
    protocol: str | None = None
    world: Path | None = None  # a site file whose [logger] is this logger's hardware
    where: str = "loggers[0]"  # the entry that declared it (for errors at start)
    hardware: HardwarePlan = field(default_factory=HardwarePlan)  # built once per logger


def parse_fleet(site: Table) -> list[FleetLogger]:
    """Every logger of the site file's ``[[loggers]]`` (empty when it has none)."""
    fleet: list[FleetLogger] = []
    serials: dict[str, str] = {}
    worlds: dict[tuple[str, Path | None], HardwarePlan] = {}
    for entry in site.tables("loggers", _KEYS):
        for logger in _entry(entry, worlds):
            if len(fleet) >= MAX_FLEET:
                raise entry.fail(
                    None, f"more than {MAX_FLEET} loggers in one file: shard the fleet"
                )
            if logger.serial_number in serials:
                raise entry.fail(
                    "serial_number",
                    f"{logger.serial_number} is also declared by {serials[logger.serial_number]}",
                )
            serials[logger.serial_number] = entry.where
            fleet.append(logger)
    return fleet


def _entry(entry: Table, worlds: dict[tuple[str, Path | None], HardwarePlan]) -> list[FleetLogger]:
    count = entry.integer("count", 1, lo=1, hi=MAX_FLEET, what=f"an integer from 1 to {MAX_FLEET}")
    first = entry.integer("first", 1, lo=0, hi=10**9, what="an integer from 0 to 1000000000")
    pattern = entry.text("serial_number")
    host, port = entry.address("listen")
    if "count" in entry and "{n" not in pattern:
        raise entry.fail("serial_number", "a numbered range needs {n} in its serial number")
    if port and port + count - 1 > 65535:
        raise entry.fail("listen", f"ports {port}..{port + count - 1} go beyond 65535")
    protocol = entry.opt_text("protocol", choices=("1.16", "2.10"))
    world = entry.opt_path("site")
    backend = entry.text("backend", "sim")
    key = (backend, world)
    if key not in worlds:
        worlds[key] = _hardware(entry, backend, world)
    hardware = worlds[key]
    loggers = []
    for n in range(first, first + count):
        serial = _serial(entry, pattern, n)
        loggers.append(
            FleetLogger(
                serial,
                (host, port + n - first if port else 0),
                protocol,
                world,
                entry.where,
                hardware,
            )
        )
    return loggers


def _hardware(entry: Table, backend: str, world: Path | None) -> HardwarePlan:
    """The hardware plan of an entry: its backend (from the registry, able to serve many
    loggers) and the ``[logger]`` of its ``site`` file, read and checked once."""
    try:
        if not registry.backend(backend).many:
            raise entry.fail(
                "backend",
                f"backend {backend!r} drives one board's real sensors and cannot serve a fleet; "
                "serve that logger as [logger]",
            )
    except registry.UnknownBackend as exc:
        raise entry.fail("backend", str(exc)) from None
    if world is None:
        return plan_hardware(None, backend)
    try:
        table = load(world)
    except ConfigError as exc:
        if exc.field != "file" or exc.path != world:
            raise
        where = f" (line {exc.line})" if exc.line is not None else ""
        raise entry.fail("site", f"{world}{where}: {exc.message}") from None
    return plan_hardware(table, backend)


def _serial(entry: Table, pattern: str, n: int) -> str:
    try:
        serial = pattern.format(n=n)
    except (KeyError, IndexError, ValueError) as exc:
        raise entry.fail(
            "serial_number", f"cannot number {pattern!r}: {exc} (use {{n}}, e.g. F{{n:04}})"
        ) from None
    if not _SERIAL.fullmatch(serial):
        raise entry.fail(
            "serial_number",
            f"{serial!r}: 1 to 32 letters, digits, '-', '_' or '.' (it names a directory)",
        )
    return serial
