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
a fleet of loggers for its ``[[loggers]]`` (:mod:`sondalog.app.fleet_site`); its
``[[scenario]]`` entries (:mod:`sondalog.app.scenario`) are run on them, or those of another
file (:func:`with_scenario`, ``serve --scenario FILE``).
Everything is read through :class:`sondalog.config.Table`: an unknown table or key anywhere
(``[loger]``, ``[bsu]``, ``intervall =``) is refused with a "did you mean", and errors name the
file, line and field (:class:`ConfigError`). :func:`load_site` returns a :class:`SitePlan`
that :func:`sondalog.app.serve.start_site` consumes without reading the file again: the
logger's hardware plan (its backend's checked description of ``[logger]``), the mail hub's
configuration, the fleet with the hardware plan of each world file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from sondalog.app.fleet_site import FleetLogger, parse_fleet
from sondalog.app.gsm_site import GsmPlan, parse_gsm_site
from sondalog.app.logger import HardwarePlan, plan_hardware
from sondalog.app.mailhub import MailHubConfig, parse_mail
from sondalog.app.scenario import ScenarioStep, parse_scenario
from sondalog.backends.linux.board import read_board_of_site
from sondalog.backends.linux.rs485 import MODES, Rs485Error, Rs485Settings, check_delays
from sondalog.backends.sim.site_bus import BusSite, read_bus_site
from sondalog.config import Table, load

DEFAULT_LOGGER_LISTEN = ("127.0.0.1", 10001)
DEFAULT_BUS_LISTEN = ("127.0.0.1", 10485)
_LOGGER_SERVE = ("listen", "protocol", "serial_number", "ptys", "serials", "line_rate", "modem")
_BUS_SERVE = ("listen", "pty", "serial", "rs485", "delay_before_tx", "delay_before_rx")
#: The top-level tables (and keys) of a site file; anything else is a misspelling.
_TOP = ("logger", "loggers", "bus", "mail", "gsm", "board", "scenario")
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
    hardware: HardwarePlan = field(default_factory=HardwarePlan)  # built at start


@dataclass(frozen=True)
class BusPlan:
    listen: tuple[str, int] = DEFAULT_BUS_LISTEN
    pty: Path | None = None
    serial: str | None = None
    rs485: Rs485Settings | None = None  # the serial port is an RS-485 adapter
    baud: int | None = None  # from [board.rs485] when [bus] has none
    #: Where an RS-485 failure at start is reported: bus.serve.rs485, else board.rs485.
    rs485_field: str = "board.rs485"
    #: The bus's modules and signals, as checked at load (``start_bus_server`` builds them).
    site: BusSite | None = None


@dataclass(frozen=True)
class SitePlan:
    """A parsed site file and what it asks to serve."""

    path: Path
    root: Table
    logger: LoggerPlan | None = None
    bus: BusPlan | None = None
    mail: MailHubConfig | None = None  # its root is set to the state directory at start
    listens: list[tuple[str, tuple[str, int]]] = field(default_factory=list)
    gsm: GsmPlan | None = None
    fleet: list[FleetLogger] = field(default_factory=list)
    scenario: list[ScenarioStep] = field(default_factory=list)

    @property
    def devices(self) -> list[str]:
        """The names the control API and a scenario give the site's devices."""
        names = ["logger"] if self.logger is not None else []
        names += [f"loggers.{member.serial_number}" for member in self.fleet]
        names += ["bus"] if self.bus is not None else []
        names += ["gsm"] if self.gsm is not None else []
        return names + (["mail"] if self.mail is not None else [])

    @property
    def data(self) -> Mapping[str, object]:
        """The parsed file."""
        return self.root.data

    @property
    def text(self) -> str:
        """The file's text (for line numbers)."""
        return self.root.source.text or ""


def load_site(path: Path) -> SitePlan:
    """Read ``path`` and check every part of it; raises :class:`ConfigError`."""
    root = load(path).keys(_TOP)
    listens: list[tuple[str, tuple[str, int]]] = []
    logger = bus = mail = gsm = None
    if (logger_table := root.opt_table("logger")) is not None:
        logger = _logger_plan(root, logger_table)
        listens.append(("logger.serve.listen", logger.listen))
    if (bus_table := root.opt_table("bus")) is not None:
        bus = _bus_plan(root, bus_table)
        listens.append(("bus.serve.listen", bus.listen))
    if (mail_table := root.opt_table("mail")) is not None:
        mail = parse_mail(mail_table, path.parent)  # (dir: the state's, set at start)
        listens.append(("mail.smtp", (mail.smtp_host, mail.smtp_port)))
        listens.append(("mail.pop3", (mail.pop3_host, mail.pop3_port)))
    if "gsm" in root:
        gsm = parse_gsm_site(root)
        listens.append(("gsm.serve.api", gsm.api))
        listens += [
            (f"gsm.modem[{i}].serve.listen", m.listen) for i, m in enumerate(gsm.modems) if m.listen
        ]
    if logger is not None and logger.modem is not None:
        numbers = [m.number for m in gsm.modems] if gsm is not None else []
        if logger.modem not in numbers:
            raise root.fail("logger.serve.modem", f"no [[gsm.modem]] with number {logger.modem}")
    fleet = parse_fleet(root)
    listens.extend((f"{member.where}.listen", member.listen) for member in fleet)
    _check_ports(root, listens)
    if logger is None and bus is None and mail is None and gsm is None and not fleet:
        raise root.fail(
            "site",
            "nothing to serve: the file has no [logger], [[loggers]], [bus], [mail] or [gsm]",
        )
    plan = SitePlan(path, root, logger, bus, mail, listens, gsm, fleet)
    return replace(plan, scenario=parse_scenario(root, plan.devices))


def with_scenario(plan: SitePlan, path: Path) -> SitePlan:
    """``plan`` running the ``[[scenario]]`` entries of the file ``path`` instead of its own
    (``serve --scenario FILE``: a file of nothing but ``[[scenario]]``)."""
    root = load(path).keys(("scenario",))
    if "scenario" not in root:
        raise root.fail("scenario", "the file has no [[scenario]] entries")
    return replace(plan, scenario=parse_scenario(root, plan.devices))


def _check_ports(root: Table, listens: list[tuple[str, tuple[str, int]]]) -> None:
    """Refuse a port that two parts of the file would listen on (port 0: any free port),
    at the second one, before anything binds."""
    used: dict[int, list[tuple[str, str]]] = {}
    for where, (host, port) in listens:
        if port == 0:
            continue
        host = "127.0.0.1" if host == "localhost" else host
        for other, other_host in used.get(port, []):
            if host == other_host or host in _ANY_HOST or other_host in _ANY_HOST:
                raise root.fail(where, f"port {port} is already used by {other}")
        used.setdefault(port, []).append((where, host))


def _logger_plan(root: Table, table: Table) -> LoggerPlan:
    serve = table.table("serve", _LOGGER_SERVE)
    hardware = plan_hardware(root)  # the backend's own check of [logger] (its keys too)
    return LoggerPlan(
        backend=hardware.backend,
        listen=serve.address("listen", "127.0.0.1:10001"),
        protocol=serve.opt_text("protocol", choices=("1.16", "2.10")),
        serial_number=serve.opt_text("serial_number"),
        ptys=tuple(Path(p) for p in _texts(serve, "ptys")),
        serials=_texts(serve, "serials"),
        line_rate=serve.flag("line_rate", False),
        modem=serve.opt_text("modem", what="the number of a [[gsm.modem]]"),
        hardware=hardware,
    )


def _texts(table: Table, key: str) -> tuple[str, ...]:
    values = table.texts(key, ())
    if not all(values):
        raise table.fail(key, "must be a list of non-empty strings")
    return tuple(values)


def _bus_plan(root: Table, table: Table) -> BusPlan:
    serve = table.table("serve", _BUS_SERVE)
    site = read_bus_site(root)  # the bus's own plan, which starting consumes
    rs485 = _rs485(serve, site.baud or 9600) if "rs485" in serve else None
    for key in ("delay_before_tx", "delay_before_rx"):
        if key in serve and rs485 is None:
            raise serve.fail(key, 'driver delays need an RS-485 mode (rs485 = "...")')
    bus = BusPlan(
        rs485=rs485,
        listen=serve.address("listen", "127.0.0.1:10485"),
        pty=Path(serve.text("pty")) if "pty" in serve else None,
        serial=serve.opt_text("serial"),
        rs485_field="bus.serve.rs485" if rs485 is not None else "board.rs485",
        site=site,
    )
    if bus.serial is None and "board" in root:
        bus = _board_rs485(bus, root, has_baud=site.baud is not None)
    return bus


def _board_rs485(bus: BusPlan, root: Table, *, has_baud: bool) -> BusPlan:
    """The bus on the board file's RS-485 adapter (``[board.rs485]``)."""
    assert root.file is not None
    board = read_board_of_site(root)
    if board is None or board.rs485 is None:
        return bus
    wired = board.rs485
    how = Rs485Settings(wired.mode, wired.delay_before_tx, wired.delay_before_rx)
    return replace(bus, serial=wired.port, rs485=how, baud=None if has_baud else wired.baud)


def _rs485(serve: Table, baud: int) -> Rs485Settings:
    chosen = serve.text("rs485", choices=MODES)
    mode = next(m for m in MODES if m == chosen)  # (as the Literal type)
    if "serial" not in serve:
        raise serve.fail("rs485", "an RS-485 mode needs the adapter: serial = PORT")
    before_tx = serve.number("delay_before_tx", 0.0, what="seconds")
    before_rx = serve.number("delay_before_rx", 0.0, what="seconds")
    try:
        check_delays(baud, before_tx, before_rx)
    except Rs485Error as exc:
        key = "delay_before_tx" if "delay_before_tx" in str(exc) else "delay_before_rx"
        raise serve.fail(key, str(exc)) from None
    return Rs485Settings(mode, before_tx, before_rx)
