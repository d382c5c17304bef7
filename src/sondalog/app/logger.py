"""One served virtual ALA1 logger: its state directory, identity, engine host and servers.

A state directory holds the module's non-volatile memory (``ala1.sqlite``, DESIGN.md point 5)
and ``identity.json``: the protocol version (§1.1) and serial number (§6.3.3) the module was
"manufactured" with. Both are fixed when the directory is created; a later start that asks for
different ones is refused (:class:`IdentityConflict`), so a 1.16 database is never served as
2.10.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.hardware import Hardware
from sondalog.backends import registry
from sondalog.backends.registry import Acquiring, BackendContext
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.config import Table, load, of
from sondalog.io.clock import Clock
from sondalog.io.host import DeviceHost
from sondalog.io.private import open_private, private_dir
from sondalog.io.pty import PtyLine
from sondalog.io.serial_line import SerialLine
from sondalog.io.tcp import TcpServer, serve_tcp

IDENTITY_FILE = "identity.json"
DATABASE_FILE = "ala1.sqlite"
#: Prefixes every sysfs and ``/dev`` path real sensors are read from (:func:`sensor_root`).
ROOT_VARIABLE = "SONDALOG_ROOT"


class IdentityConflict(Exception):
    """The state directory was created with another protocol version or serial number."""


def valid_serial_number(serial: str) -> bool:
    """A serial number is 1 to 32 printable ASCII characters without spaces (sondalog rule)."""
    return 0 < len(serial) <= 32 and all(33 <= ord(c) < 127 for c in serial)


def load_identity(
    state_dir: Path, version: Version | None = None, serial_number: str | None = None
) -> Identity:
    """The identity of the module in ``state_dir``; created from the arguments when new.

    ``None`` means "whatever the directory says" (or the default for a new directory).
    """
    path = state_dir / IDENTITY_FILE
    if path.exists():
        return parse_identity(state_dir, path.read_text(encoding="utf-8"), version, serial_number)
    identity = Identity(version or Version.V2_10, serial_number or Identity().serial_number)
    private_dir(state_dir)
    tmp = path.with_suffix(".tmp")
    with open_private(tmp) as handle:
        handle.write(identity_text(identity))
        handle.flush()
        os.fsync(handle.fileno())
    tmp.replace(path)
    return identity


def parse_identity(
    state_dir: Path, text: str, version: Version | None, serial_number: str | None
) -> Identity:
    """The identity of ``state_dir``'s ``identity.json`` (its ``text``); IdentityConflict
    when it is not that ``version`` or ``serial_number`` (None: any)."""
    stored = json.loads(text)
    identity = Identity(Version(stored["protocol"]), str(stored["serial_number"]))
    if version is not None and version is not identity.version:
        raise IdentityConflict(
            f"{state_dir} holds a protocol {identity.version.value} logger; "
            f"it cannot be served as protocol {version.value}"
        )
    if serial_number is not None and serial_number != identity.serial_number:
        raise IdentityConflict(
            f"{state_dir} holds the logger with serial number {identity.serial_number}; "
            f"it cannot be served as serial number {serial_number}"
        )
    return identity


def identity_text(identity: Identity) -> str:
    """The text of an ``identity.json``."""
    data = {"protocol": identity.version.value, "serial_number": identity.serial_number}
    return json.dumps(data, indent=2) + "\n"


@dataclass
class Logger:
    """A running virtual logger: engine host plus its TCP servers, ptys and serial ports."""

    identity: Identity
    store: SqliteNvStore
    host: DeviceHost
    servers: list[TcpServer]
    ptys: list[PtyLine] = field(default_factory=list)
    serials: list[SerialLine] = field(default_factory=list)
    #: The hardware's sample-and-hold task, for a backend that acquires (a real board).
    acquisition: asyncio.Task[None] | None = None

    async def close(self) -> None:
        if self.acquisition is not None:
            self.acquisition.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self.acquisition
        for server in self.servers:
            await server.close()
        for pty in self.ptys:
            pty.close()
        for port in self.serials:
            await port.close()
        await self.host.stop()
        self.store.close()


def protocol_versions() -> list[str]:
    """The protocol versions a new logger can speak (``logger serve --protocol``)."""
    return [v.value for v in Version]


def protocol_version(text: str | None) -> Version | None:
    """``2.10`` as the core's :class:`~sondalog.ala1.Version` (``None``: the default);
    raises ``ValueError`` for a version not in :func:`protocol_versions`."""
    return Version(text) if text is not None else None


async def start_logger(
    state_dir: Path,
    clock: Clock,
    listen: tuple[str, int],
    version: Version | None = None,
    serial_number: str | None = None,
    on_listening: Callable[[str, int], None] | None = None,
    hardware: Hardware | None = None,
    ptys: Sequence[Path] = (),
    serials: Sequence[str] = (),
    line_rate: bool = False,
) -> Logger:
    """Open ``state_dir`` (creating it), start the engine and listen on ``listen``.

    Each path in ``ptys`` becomes a pty line (a stable symlink to its slave), each device in
    ``serials`` a serial line; both are paced at ``com speed``. ``line_rate`` paces the TCP
    lines too. Every line has its own line state. ``on_listening`` is called once all of
    them are ready.
    """
    private_dir(state_dir)  # 0700, its files 0600 (docs/security.md)
    identity = load_identity(state_dir, version, serial_number)
    store = SqliteNvStore(state_dir / DATABASE_FILE)
    logger: Logger | None = None
    try:
        engine = Engine(identity, store, clock.now(), hardware, line_time_scale=clock.speed)
        host = DeviceHost(engine, clock)
        logger = Logger(identity, store, host, [])
        if isinstance(hardware, Acquiring):  # a real board: its acquisition task runs here
            logger.acquisition = asyncio.create_task(hardware.run(), name="acquisition")
        logger.servers.append(await serve_tcp(host, *listen, paced=line_rate))
        for path in ptys:
            logger.ptys.append(PtyLine(host, path))
        for device in serials:
            port = SerialLine(host, device)
            await port.open()
            logger.serials.append(port)
        host.start()
    except BaseException:
        if logger is not None:
            await logger.close()
        else:
            store.close()
        raise
    server = logger.servers[0]
    if on_listening is not None:
        on_listening(*server.address)
    return logger


async def serve_until(stop: asyncio.Event, logger: Logger) -> None:
    """Serve until ``stop`` is set, then close everything."""
    try:
        await stop.wait()
    finally:
        await logger.close()


@dataclass(frozen=True)
class HardwarePlan:
    """A logger's hardware as loaded from a site file: the backend's name and the context
    it is built in, with what the backend's ``plan`` made of ``[logger]`` (``context.plan``).
    :meth:`build` makes the hardware at start without reading the file again."""

    backend: str = "sim"
    context: BackendContext = field(default_factory=BackendContext)

    def build(self, start: float, root: Path = Path("/"), speed: float = 1.0) -> Hardware:
        context = replace(self.context, start=start, root=root, speed=speed)
        return create_hardware(self.backend, context)


#: The keys of ``[logger]`` for a backend without config parsing of its own.
_LOGGER_KEYS = ("backend", "serve")


def plan_hardware(site: Table | None, backend: str | None = None) -> HardwarePlan:
    """The hardware plan of the site file ``site`` (its root table; ``None``: no file).

    The backend is ``[logger] backend`` (default ``sim``), or ``backend`` if given (a fleet
    entry's; the file's ``[logger]`` may then only name the same one). Its registry entry
    checks ``[logger]`` here; raises :class:`~sondalog.config.ConfigError`."""
    site = site if site is not None else of({})
    logger = site.opt_table("logger")
    name = backend or "sim"
    if logger is not None:
        name = logger.text("backend", name)
        if backend is not None and name != backend:
            raise logger.fail("backend", f"names {name!r}, but it is served by {backend!r}")
    try:
        entry = registry.backend(name)
    except registry.UnknownBackend as exc:
        raise site.fail("logger.backend", str(exc)) from exc
    made: object = None
    if entry.plan is not None:
        made = entry.plan(logger if logger is not None else of({}, site.file, where="logger"))
    elif logger is not None:
        logger.keys(_LOGGER_KEYS)
    return HardwarePlan(name, BackendContext(site.data, site.file, site.source.text, plan=made))


def logger_hardware(site: Path | None, start: float, speed: float = 1.0) -> Hardware:
    """The hardware of ``logger serve --site FILE``: the backend the site file names
    (``[logger] backend``, default ``sim``); without a file, a 12 V supply and nothing else.
    Raises :class:`~sondalog.config.ConfigError`."""
    plan = plan_hardware(load(site) if site is not None else None)
    return plan.build(start, sensor_root() if site is not None else Path("/"), speed)


def sensor_root() -> Path:
    """Where sysfs and ``/dev`` are: ``SONDALOG_ROOT`` (a fake kernel tree in tests, a
    chroot), else ``/``."""
    return Path(os.environ.get(ROOT_VARIABLE) or "/")


def create_hardware(backend: str, context: BackendContext) -> Hardware:
    """Backend ``backend`` built for ``context``; an unknown one is a
    :class:`~sondalog.config.ConfigError` at ``logger.backend`` of the site file ``context``
    was read from."""
    try:
        return registry.create(backend, context)
    except registry.UnknownBackend as exc:
        site = of(context.site, context.path, context.text)
        raise site.fail("logger.backend", str(exc)) from exc
