"""What a site file asks ``sondalog serve`` to run (the one site-file loader of the wiring).

A site file describes a place: its logger (``[logger]``: the simulated hardware, or
``backend = "linux"``), its RS-485 bus (``[bus]``), its mail hub (``[mail]``). How each is
served is said in a ``serve`` table beside it; everything has a default::

    [logger.serve]
    listen = "127.0.0.1:10001"      # TCP, one line per connection
    protocol = "2.10"               # or "1.16"; fixed once the state directory exists
    serial_number = "A1-0001"
    ptys = ["/tmp/ala1"]            # pty lines (stable symlinks), paced at com speed
    modem = "+420600000001"         # the com line drives this modem of [gsm] (AT bytes)
    serials = ["/dev/ttyUSB0"]      # real serial ports
    line_rate = false               # pace TCP answers too

    [bus.serve]
    listen = "127.0.0.1:10485"
    pty = "/tmp/rs485"
    serial = "/dev/ttyUSB1"
    rs485 = "auto"                  # the serial port is an RS-485 adapter: kernel | rts | auto
    delay_before_tx = 0.0           # driver delays (rs485 only), seconds
    delay_before_rx = 0.0

Without ``serial`` in ``[bus.serve]``, a board file's ``[board.rs485]`` (port, baud, mode,
delays) serves the bus on that adapter.

A logger is served when the file has a ``[logger]`` table; a bus when it has ``[bus]``; a mail
hub when it has ``[mail]``; a GSM network when it has ``[gsm]`` (:mod:`sondalog.app.gsm_site`);
a fleet of loggers for its ``[[loggers]]`` (:mod:`sondalog.app.fleet_site`).
Errors name the file, line and field (:class:`ConfigError`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from sondalog.app.fleet_site import FleetLogger, parse_fleet
from sondalog.app.gsm_site import GsmPlan, parse_gsm_site
from sondalog.app.mailhub import parse_mail
from sondalog.backends.linux.board import board_of_site
from sondalog.backends.linux.rs485 import MODES, Rs485Error, Rs485Settings, check_delays
from sondalog.backends.sim.logger import parse_logger_site
from sondalog.backends.sim.site_bus import parse_bus_site
from sondalog.config import ConfigError, Fail, locate, of, read_site_file, serve_table, unknown
from sondalog.config.address import parse_listen

DEFAULT_LOGGER_LISTEN = ("127.0.0.1", 10001)
DEFAULT_BUS_LISTEN = ("127.0.0.1", 10485)
_LOGGER_SERVE = {"listen", "protocol", "serial_number", "ptys", "serials", "line_rate", "modem"}
_BUS_SERVE = {"listen", "pty", "serial", "rs485", "delay_before_tx", "delay_before_rx"}
#: The top-level tables (and keys) of a site file; anything else is a misspelling.
_TOP = {"logger", "loggers", "bus", "mail", "gsm", "board"}
#: Hosts that bind every address: their port clashes with the same port on any host.
_ANY_HOST = {"", "0.0.0.0", "::", "*"}


@dataclass(frozen=True)
class LoggerPlan:
    backend: str = "sim"
    listen: tuple[str, int] = DEFAULT_LOGGER_LISTEN
    protocol: str | None = None
    serial_number: str | None = None
    ptys: tuple[Path, ...] = ()
    serials: tuple[str, ...] = ()
    line_rate: bool = False
    modem: str | None = None  # the com line drives this modem of [gsm] (its number)


@dataclass(frozen=True)
class BusPlan:
    listen: tuple[str, int] = DEFAULT_BUS_LISTEN
    pty: Path | None = None
    serial: str | None = None
    rs485: Rs485Settings | None = None  # the serial port is an RS-485 adapter
    baud: int | None = None  # from [board.rs485] when [bus] has none


@dataclass(frozen=True)
class SitePlan:
    """A parsed site file and what it asks to serve."""

    path: Path
    data: Mapping[str, object]
    text: str
    logger: LoggerPlan | None = None
    bus: BusPlan | None = None
    mail: Mapping[str, object] | None = None
    listens: list[tuple[str, tuple[str, int]]] = field(default_factory=list)
    gsm: GsmPlan | None = None
    fleet: list[FleetLogger] = field(default_factory=list)


def load_site(path: Path) -> SitePlan:
    """Read ``path`` and check its ``serve`` tables; raises :class:`ConfigError`."""
    data, text = read_site_file(path)

    def fail(where: str, message: str) -> ConfigError:
        return ConfigError(path, where, message, locate(text, where))

    def table(name: str) -> Mapping[str, object] | None:
        found = data.get(name)
        if found is not None and not isinstance(found, Mapping):
            raise fail(name, "must be a table")
        return found

    for name in data:
        if name not in _TOP:
            raise fail(name, unknown(name, _TOP))
    listens: list[tuple[str, tuple[str, int]]] = []
    logger = bus = None
    if (logger_table := table("logger")) is not None:
        logger = _logger_plan(logger_table, fail)
        listens.append(("logger.serve.listen", logger.listen))
    if (bus_table := table("bus")) is not None:
        bus = _bus_plan(bus_table, fail)
        listens.append(("bus.serve.listen", bus.listen))
    mail = table("mail")
    if mail is not None:
        hub = parse_mail(of(mail, path, text, "mail"), path.parent)  # (dir: the state's)
        listens.append(("mail.smtp", (hub.smtp_host, hub.smtp_port)))
        listens.append(("mail.pop3", (hub.pop3_host, hub.pop3_port)))
    if bus is not None:
        parse_bus_site(data, 0.0, path, text)  # every part is checked before any starts
        if bus.serial is None and "board" in data:
            bus = _board_rs485(bus, data, path, text)
    if logger is not None and logger.backend == "sim":
        parse_logger_site(data, 0.0, path, text)
    gsm = parse_gsm_site(of(data, path, text)) if "gsm" in data else None
    if gsm is not None:
        listens.append(("gsm.serve.api", gsm.api))
        listens += [
            (f"gsm.modem[{i}].serve.listen", m.listen) for i, m in enumerate(gsm.modems) if m.listen
        ]
    if logger is not None and logger.modem is not None:
        numbers = [m.number for m in gsm.modems] if gsm is not None else []
        if logger.modem not in numbers:
            raise fail("logger.serve.modem", f"no [[gsm.modem]] with number {logger.modem}")
    fleet = parse_fleet(data, path, text)
    _check_worlds(fleet, fail)
    listens.extend((f"{member.where}.listen", member.listen) for member in fleet)
    _check_ports(listens, fail)
    if logger is None and bus is None and mail is None and gsm is None and not fleet:
        raise fail(
            "site",
            "nothing to serve: the file has no [logger], [[loggers]], [bus], [mail] or [gsm]",
        )
    return SitePlan(path, data, text, logger, bus, mail, listens, gsm, fleet)


def _check_worlds(fleet: list[FleetLogger], fail: Fail) -> None:
    """Read and check every site file a ``[[loggers]]`` entry names (``site =``), as the
    start will; a file that cannot be read is reported at the line that names it."""
    seen: set[Path] = set()
    for member in fleet:
        if member.world is None or member.world in seen:
            continue
        seen.add(member.world)
        try:
            data, text = read_site_file(member.world)
        except ConfigError as exc:
            if exc.field != "file" or exc.path != member.world:
                raise
            where = f" (line {exc.line})" if exc.line is not None else ""
            raise fail(f"{member.where}.site", f"{member.world}{where}: {exc.message}") from None
        parse_logger_site(data, 0.0, member.world, text)


def _check_ports(listens: list[tuple[str, tuple[str, int]]], fail: Fail) -> None:
    """Refuse a port that two parts of the file would listen on (port 0: any free port),
    at the second one, before anything binds."""
    used: dict[int, list[tuple[str, str]]] = {}
    for where, (host, port) in listens:
        if port == 0:
            continue
        host = "127.0.0.1" if host == "localhost" else host
        for other, other_host in used.get(port, []):
            if host == other_host or host in _ANY_HOST or other_host in _ANY_HOST:
                raise fail(where, f"port {port} is already used by {other}")
        used.setdefault(port, []).append((where, host))


def _listen(value: object, where: str, fail: Fail) -> tuple[str, int]:
    """A ``listen = "HOST:PORT"`` field of a ``serve`` table."""
    if not isinstance(value, str):
        raise fail(where, 'must be "HOST:PORT"')
    try:
        return parse_listen(value)
    except ValueError as exc:
        raise fail(where, str(exc)) from None


def _text(value: object, where: str, fail: Fail) -> str:
    if not isinstance(value, str) or not value:
        raise fail(where, "must be a non-empty string")
    return value


def _texts(value: object, where: str, fail: Fail) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise fail(where, "must be a list of strings")
    return tuple(value)


def _logger_plan(table: Mapping[str, object], fail: Fail) -> LoggerPlan:
    serve = serve_table(table, "logger", _LOGGER_SERVE, fail)
    backend = table.get("backend", "sim")
    if not isinstance(backend, str):
        raise fail("logger.backend", "must be a backend name")
    protocol = serve.get("protocol")
    if protocol is not None and protocol not in ("1.16", "2.10"):
        raise fail("logger.serve.protocol", 'must be "1.16" or "2.10"')
    modem = serve.get("modem")
    if modem is not None and (not isinstance(modem, str) or not modem):
        raise fail("logger.serve.modem", "must be the number of a [[gsm.modem]]")
    line_rate = serve.get("line_rate", False)
    if not isinstance(line_rate, bool):
        raise fail("logger.serve.line_rate", "must be true or false")
    return LoggerPlan(
        backend=backend,
        listen=_listen(serve["listen"], "logger.serve.listen", fail)
        if "listen" in serve
        else DEFAULT_LOGGER_LISTEN,
        protocol=str(protocol) if protocol is not None else None,
        serial_number=_text(serve["serial_number"], "logger.serve.serial_number", fail)
        if "serial_number" in serve
        else None,
        ptys=tuple(Path(p) for p in _texts(serve.get("ptys", []), "logger.serve.ptys", fail)),
        serials=_texts(serve.get("serials", []), "logger.serve.serials", fail),
        line_rate=line_rate,
        modem=modem,
    )


def _board_rs485(bus: BusPlan, data: Mapping[str, object], path: Path, text: str) -> BusPlan:
    """The bus on the board file's RS-485 adapter (``[board.rs485]``)."""
    board = board_of_site(data, path, text)
    if board is None or board.rs485 is None:
        return bus
    wired = board.rs485
    how = Rs485Settings(wired.mode, wired.delay_before_tx, wired.delay_before_rx)
    bus_table = data.get("bus")
    has_baud = isinstance(bus_table, Mapping) and "baud" in bus_table
    return replace(bus, serial=wired.port, rs485=how, baud=None if has_baud else wired.baud)


def _rs485(table: Mapping[str, object], serve: Mapping[str, object], fail: Fail) -> Rs485Settings:
    mode = serve["rs485"]
    if mode not in MODES:
        raise fail("bus.serve.rs485", f"must be one of {', '.join(MODES)}, not {mode!r}")
    if "serial" not in serve:
        raise fail("bus.serve.rs485", "an RS-485 mode needs the adapter: serial = PORT")
    delays = []
    for key in ("delay_before_tx", "delay_before_rx"):
        value = serve.get(key, 0.0)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise fail(f"bus.serve.{key}", f"must be seconds, not {value!r}")
        delays.append(float(value))
    baud = table.get("baud")
    try:
        check_delays(baud if isinstance(baud, int) and baud > 0 else 9600, *delays)
    except Rs485Error as exc:
        key = "delay_before_tx" if "delay_before_tx" in str(exc) else "delay_before_rx"
        raise fail(f"bus.serve.{key}", str(exc)) from None
    return Rs485Settings(mode, delays[0], delays[1])


def _bus_plan(table: Mapping[str, object], fail: Fail) -> BusPlan:
    serve = serve_table(table, "bus", _BUS_SERVE, fail)
    rs485 = _rs485(table, serve, fail) if "rs485" in serve else None
    for key in ("delay_before_tx", "delay_before_rx"):
        if key in serve and rs485 is None:
            raise fail(f"bus.serve.{key}", 'driver delays need an RS-485 mode (rs485 = "...")')
    return BusPlan(
        rs485=rs485,
        listen=_listen(serve["listen"], "bus.serve.listen", fail)
        if "listen" in serve
        else DEFAULT_BUS_LISTEN,
        pty=Path(_text(serve["pty"], "bus.serve.pty", fail)) if "pty" in serve else None,
        serial=_text(serve["serial"], "bus.serve.serial", fail) if "serial" in serve else None,
    )
