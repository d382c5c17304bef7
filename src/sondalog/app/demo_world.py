"""The world of ``make demo``: its site files, the loggers' settings and their history.

:func:`write_world` writes into the demo's state directory a site file per logger, one for the
RS-485 bus and the mail hub, and the collector's configuration; :func:`fast_forward` gives a
new logger its channel settings through the protocol (as a user would, §6.5) and steps it
through :data:`HISTORY_DAYS` days of module time (:class:`~sondalog.app.virtual.VirtualLogger`
on the logger's own state directory), so the served logger starts with a full record.
:func:`simulated_sensors` gives the served logger the same simulated sensors, built from the same
site file with the same signal origin, so its live rows go on where the history ends.

The loggers on cable lines are :data:`LOGGERS`; the logger in the field with a GSM modem
sending its rows by e-mail is :data:`GSM`, served with the demo's GSM network (``GSM LOGGER``
below).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from sondalog.ala1.model import Version
from sondalog.app.demo_alarms import (
    ALARM_PHONE,
    LEVEL_FILE,
    MAILBOX_SOURCE,
    OPS_MAIL,
    AlarmWorld,
    alarm_toml,
    level_csv,
)
from sondalog.app.logger import DATABASE_FILE, load_identity
from sondalog.app.virtual import VirtualLogger
from sondalog.backends.sim.logger import SimHardware
from sondalog.backends.sim.logger_site import load_logger_site
from sondalog.io.private import private_dir

#: Days of module time each logger has recorded when the demo starts.
HISTORY_DAYS = 28
#: Module seconds per fast-forward step (signals are evaluated at each step's time).
STEP = 300.0


@dataclass(frozen=True)
class DemoLogger:
    """One virtual logger of the demo."""

    key: str  # directory and collector source name
    serial: str
    port: int  # preferred TCP port (a free one when taken)
    what: str  # one line for the user
    site: str  # the [logger] part of its site file
    settings: tuple[str, ...]  # command lines that configure it (§6.5)


CABLE = DemoLogger(
    "cable",
    "CABLE-01",
    10001,
    "on a cable line: supply, water level, water temperature",
    """[logger]
seed = 7
supply = { model = "sine", mean = 12.4, amplitude = 0.3, period = 86400 }
supply_power = 1

[[logger.analog]]               # a water-level sensor on K2 pin 5, powered by output 2
address = 16
power = 2
# its level: a wandering river with a flood wave an hour after the demo starts (level.csv)
signal = { model = "csv", path = "level.csv", loop = true }

[[logger.ds18b20]]              # a thermometer in the water on P6 bit 4
pin = 4
signal = { model = "sine", mean = 9.0, amplitude = 2.5, period = 86400, phase = -28800 }
""",
    (
        "write channel max number 3",
        "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 2",
        "write output 2 device 1 write output 2 address 6",
        "write device 3 type ds18b20 write device 3 address 4",
        "write channel 3 device 3 write channel 3 type 3 write channel 3 address 0",
        "write channel 1 name/Supply[V]/ write channel 2 name/Level[V]/",
        "write channel 3 name/Water[C]/ write channel 2 format 5.3",
        "write channel 1 sampling period 0005 write channel 2 sampling period 0005",
        "write channel 3 sampling period 0005",
    ),
)

RAIN = DemoLogger(
    "rain",
    "RAIN-02",
    10002,
    "a field station: air temperature, a rain gauge (type-6 event channel), modem signal",
    """[logger]
seed = 5
supply = { model = "sine", mean = 12.6, amplitude = 0.4, period = 86400 }

[[logger.ds18b20]]              # air temperature on P6 bit 4
pin = 4
signal = { model = "sine", mean = 12.0, amplitude = 7.0, period = 86400, phase = -21600 }

[[logger.pulses]]               # a tipping-bucket rain gauge on the timer input P1.0
timer = true
poisson = { rate = 0.00004, burst = 6, seed = 2 }

[logger.gsm]                    # what channel types 12 (signal) and 11 (credit) read
credit = { model = "ramp", start = 300.0, rate = -0.00005, min = 0 }
[logger.gsm.signal]
model = "random_walk"
start = 20
step = 1
interval = 600
seed = 4
min = 8
max = 31
""",
    (
        "write channel max number 5",
        "write device 3 type ds18b20 write device 3 address 4",
        "write channel 2 device 3 write channel 2 type 3 write channel 2 address 0",
        "write device 4 type msp430ta write channel 3 device 4 write channel 3 type 6",
        "write channel 4 type 12 write channel 5 type 11",
        "write channel 1 name/Supply[V]/ write channel 2 name/Air[C]/",
        "write channel 3 name/Rain[imp]/ write channel 4 name/Signal/",
        "write channel 5 name/Credit[CZK]/",
        "write channel 1 sampling period 0005 write channel 2 sampling period 0005",
        "write channel 3 sampling period 0005 write channel 4 sampling period 0030",
        "write channel 5 sampling period 01",
    ),
)

# GSM LOGGER: the logger in the field with a modem of the demo's GSM network (gsm.md): its
# site file has the network too (served by the same machinery as `sondalog serve`,
# :func:`gsm_site`); once served it is told (:func:`gsm_message_settings`) to send its new
# rows by e-mail every hour to the demo's mail hub, which the collector reads with a mailbox
# source (:func:`collector_toml`).
GSM = DemoLogger(
    "gsm",
    "GSM-03",
    10003,
    "in the field with a GSM modem: sends its new rows by e-mail every hour",
    """[logger]
seed = 11
supply = { model = "sine", mean = 12.2, amplitude = 0.2, period = 86400 }

[[logger.ds18b20]]              # soil temperature on P6 bit 4
pin = 4
signal = { model = "sine", mean = 8.0, amplitude = 2.0, period = 86400, phase = -25200 }

[logger.gsm]                    # what the network reports for its modem (types 12 and 11)
signal = { model = "sine", mean = 18, amplitude = 4, period = 3600 }
credit = { model = "constant", value = 250.0 }
""",
    (
        "write channel max number 4",
        "write device 3 type ds18b20 write device 3 address 4",
        "write channel 2 device 3 write channel 2 type 3 write channel 2 address 0",
        "write channel 3 type 12 write channel 4 type 11",
        "write channel 1 name/Supply[V]/ write channel 2 name/Soil[C]/",
        "write channel 3 name/Signal/ write channel 4 name/Credit[CZK]/",
        "write channel 1 sampling period 0015 write channel 2 sampling period 0015",
        "write channel 3 sampling period 0015 write channel 4 sampling period 0015",
    ),
)
#: The GSM logger's names and units for the collector, which only reads its e-mails.
GSM_CHANNELS = 'channels = { 1 = "Supply [V]", 2 = "Soil [C]", 3 = "Signal", 4 = "Credit [CZK]" }'
#: The GSM logger's history is short: its first e-mail carries all of it.
GSM_HISTORY_DAYS = 2
GSM_MODEM, GSM_PHONE = "+420600000003", "+420700000001"
#: The network's USSD code that answers the modem's credit (``gsm_site``).
GSM_CREDIT_CODE = "*101#"
LOGGER_MAIL, USER_MAIL = "logger@example.net", "user@example.net"


def gsm_site(
    listen: tuple[str, int], api: tuple[str, int], outage: tuple[float, float] | None = None
) -> str:
    """The GSM logger's whole site file: the logger, its modem, the network and a phone;
    ``outage``: when its modem has no coverage (seconds since the epoch of the network's
    real-time clock, :func:`~sondalog.app.demo_alarms.coverage_outage`)."""
    lost = ""
    if outage is not None:
        lost = (
            "\n[[gsm.outage]]                 # the modem loses coverage for a while\n"
            f'number = "{GSM_MODEM}"\nstart = {outage[0]:.0f}\nend = {outage[1]:.0f}\n'
        )
    return f"""# The demo logger {GSM.serial} with its modem {GSM_MODEM} and the demo's GSM network.
{GSM.site}
[logger.serve]
listen = "{listen[0]}:{listen[1]}"
protocol = "2.10"
modem = "{GSM_MODEM}"

[gsm]
logger_modem = "{GSM_MODEM}"
hosts = {{ "smtp.example.net" = "127.0.0.1", "pop3.example.net" = "127.0.0.1" }}

[gsm.serve]
api = "{api[0]}:{api[1]}"

[[gsm.modem]]
number = "{GSM_MODEM}"
credit = 250.0
ussd = {{ "{GSM_CREDIT_CODE}" = "Your credit is {{credit:.2f}} CZK. Thank you." }}

[[gsm.phone]]
number = "{GSM_PHONE}"

[[gsm.phone]]                   # the collector's SIM: it sends the alarms' SMS
number = "{ALARM_PHONE}"
{lost}"""


def gsm_message_settings(smtp_port: int) -> tuple[str, ...]:
    """What a user types to have the GSM logger e-mail its new rows every hour (§6.14), and
    ask the network its credit (USSD ``*101#``, the number after ``credit is``) at each of
    its communications, as it reads its signal (§6.11.7): channel types 12 and 11 hold the
    last values read. The first e-mail goes at once, so they have values from the start."""
    return (
        "write com device wavecom41",
        f"write com status sim credit code !{GSM_CREDIT_CODE}!credit is",
        f"write com network smtp address {LOGGER_MAIL}:secret@smtp.example.net:{smtp_port}",
        f"write email send from {LOGGER_MAIL}",
        f"write address 1 type email write address 1 value {USER_MAIL}",
        "write command 1 value/read record 1000 from lastread shift/",
        "write message 1 command 1 write message 1 address 1",
        "write message 1 period 010000",
        "write message 1 run 1",
        "write com close",
    )


#: The loggers on a cable line of their own (the GSM logger is served with its network).
LOGGERS: tuple[DemoLogger, ...] = (CABLE, RAIN)

BUS_MODULES = {"T1": "C", "H1": "%"}
BUS_SITE = """[bus]
baud = 9600
seed = 42

[[bus.modules]]                 # a room that warms by day
id = "T1"
kind = "temp"
signal = { model = "sine", mean = 21.0, amplitude = 3.0, period = 3600, phase = 900 }

[[bus.modules]]                 # its humidity
id = "H1"
kind = "hum"
[bus.modules.signal]
model = "random_walk"
start = 45.0
step = 0.5
interval = 10
seed = 9
min = 30
max = 70
"""
MAIL_ACCOUNTS = {LOGGER_MAIL: "secret", USER_MAIL: "secret", OPS_MAIL: "secret"}


def write_world(state: Path) -> None:
    """The site files of :data:`LOGGERS` and of the bus (``bus.toml``), and the water level
    ``CABLE-01``'s site file reads (:func:`~sondalog.app.demo_alarms.level_csv`)."""
    private_dir(state)  # the demo's state, private like any (docs/security.md)
    (state / LEVEL_FILE).write_text(level_csv(HISTORY_DAYS), encoding="utf-8")
    for logger in (*LOGGERS, GSM):
        (state / f"{logger.key}.toml").write_text(
            f"# The demo logger {logger.serial}: {logger.what}.\n{logger.site}", encoding="utf-8"
        )
    (state / "bus.toml").write_text(
        "# The demo's RS-485 bus: two HCTMPS1 modules.\n" + BUS_SITE, encoding="utf-8"
    )


def collector_toml(
    loggers: dict[str, tuple[str, int]],
    bus: tuple[str, int],
    web: tuple[str, int],
    pop3: tuple[str, int] | None = None,
    alarms: AlarmWorld | None = None,
) -> str:
    """The collector's configuration: every logger, the bus, the dashboard on ``web``, the
    GSM logger's e-mails in the mailbox on ``pop3``, and the demo's alarms notifying through
    ``alarms`` (:mod:`sondalog.app.demo_alarms`)."""
    parts = [
        "# The demo's collector: written by `make demo`, see docs/collector.md.",
        '[sqlite]\npath = "collector.sqlite"',
        f'[web]\nlisten = "{web[0]}:{web[1]}"',
    ]
    for key, (host, port) in loggers.items():
        parts.append(
            f'[[source]]\nname = "{key}"\nurl = "tcp://{host}:{port}"\ninterval = 5\ntimeout = 10'
        )
    units = ", ".join(f'{m} = "{u}"' for m, u in BUS_MODULES.items())
    modules = ", ".join(f'"{m}"' for m in BUS_MODULES)
    parts.append(
        f'[[source]]\nname = "bus"\nkind = "bus"\nurl = "tcp://{bus[0]}:{bus[1]}"\n'
        f"modules = [{modules}]\nunits = {{ {units} }}\ninterval = 3"
    )
    if pop3 is not None:
        parts.append(
            f'[[source]]\nname = "{MAILBOX_SOURCE}"\nkind = "mailbox"\n'
            f'url = "pop3://{USER_MAIL}:secret@{pop3[0]}:{pop3[1]}"\n'
            f'loggers = {{ "{LOGGER_MAIL}" = "{GSM.serial}" }}\n'
            "signal = 3\ncredit = 4\ninterval = 5\n" + GSM_CHANNELS
        )
    if alarms is not None:
        parts.append(alarm_toml(alarms))
    return "\n\n".join(parts) + "\n"


class SettingRefused(RuntimeError):
    """A demo logger answered a setting with something else than OK."""


def history_origin(days: float = HISTORY_DAYS) -> float:
    """The host time ``days`` before now: where the demo's history and its signals start."""
    return time.time() - days * 86400


def simulated_sensors(state: Path, logger: DemoLogger, origin: float) -> SimHardware:
    """The simulated sensors of ``logger`` from its site file in ``state`` (the ``sim``
    backend), the signals starting at ``origin``: what :func:`fast_forward` records the
    history with, and what the served logger samples live. With the history's origin, a
    random walk goes on live from its last recorded value instead of starting over.
    Raises :class:`~sondalog.config.ConfigError`."""
    return load_logger_site(state / f"{logger.key}.toml", origin)


def fast_forward(
    state: Path,
    logger: DemoLogger,
    days: float = HISTORY_DAYS,
    directory: Path | None = None,
    origin: float | None = None,
) -> int:
    """Configure the new logger in ``directory`` (default ``state / logger.key``) and record
    ``days`` of history ending now, its signals starting at ``origin`` (default the
    history's start; :func:`simulated_sensors`); returns the bytes of record it holds then
    (``record status``). Module time is this computer's local time."""
    directory = directory if directory is not None else state / logger.key
    load_identity(directory, Version.V2_10, logger.serial)
    start = history_origin(days)
    virtual = VirtualLogger(
        database=directory / DATABASE_FILE,
        serial_number=logger.serial,
        hardware=simulated_sensors(state, logger, start if origin is None else origin),
        start=start,
    )
    # a throw-away history: no fsync per sample (the served logger opens it with FULL again)
    virtual.store.conn.execute("PRAGMA synchronous=OFF")
    try:
        stamp = datetime.fromtimestamp(start).strftime("%Y%m%d%H%M%S")
        for line in (f"write date {stamp}", *logger.settings):
            answer = virtual.command(line)
            if answer.strip() != "OK":
                raise SettingRefused(f"{logger.serial}: {line!r} -> {answer.strip()!r}")
        steps = int(days * 86400 / STEP)
        for _ in range(steps):
            virtual.step(STEP)
        status = virtual.command("read record status").split(",", 1)[0]
    finally:
        virtual.close()
    return int(status) if status.isdigit() else 0
