"""The world of ``make demo``: its site files, the loggers' settings and their history.

:func:`write_world` writes into the demo's state directory a site file per logger, one for the
RS-485 bus and the mail hub, and the collector's configuration; :func:`fast_forward` gives a
new logger its channel settings through the protocol (as a user would, §6.5) and steps it
through :data:`HISTORY_DAYS` days of module time (:class:`~sondalog.app.virtual.VirtualLogger`
on the logger's own state directory), so the served logger starts with a full record.

The loggers are :data:`LOGGERS`. A logger in the field with a GSM modem sending its rows by
e-mail belongs in that list too, once the GSM world can be served (see ``GSM LOGGER`` below).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from sondalog.ala1.model import Version
from sondalog.app.logger import DATABASE_FILE, load_identity
from sondalog.app.virtual import VirtualLogger

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
[logger.analog.signal]
model = "random_walk"
start = 1.1
step = 0.01
interval = 300
seed = 3
min = 0.3
max = 1.9

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

# GSM LOGGER: the logger in the field with a modem that sends its new rows by e-mail every
# hour (gsm.md) goes here as a third DemoLogger once the GSM world can be served: its site
# file then has a [logger.modem] part, the mail hub below receives its messages, and the
# collector reads them with a mailbox source (a [[source]] of kind "mailbox").
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
MAIL_ACCOUNTS = {"logger@example.net": "secret", "user@example.net": "secret"}


def write_world(state: Path) -> None:
    """The site files of :data:`LOGGERS` and of the bus (``bus.toml``)."""
    state.mkdir(parents=True, exist_ok=True)
    for logger in LOGGERS:
        (state / f"{logger.key}.toml").write_text(
            f"# The demo logger {logger.serial}: {logger.what}.\n{logger.site}", encoding="utf-8"
        )
    (state / "bus.toml").write_text(
        "# The demo's RS-485 bus: two HCTMPS1 modules.\n" + BUS_SITE, encoding="utf-8"
    )


def collector_toml(
    loggers: dict[str, tuple[str, int]], bus: tuple[str, int], web: tuple[str, int]
) -> str:
    """The collector's configuration: every logger, the bus, the dashboard on ``web``."""
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
    return "\n\n".join(parts) + "\n"


class SettingRefused(RuntimeError):
    """A demo logger answered a setting with something else than OK."""


def fast_forward(state: Path, logger: DemoLogger, days: float = HISTORY_DAYS) -> int:
    """Configure the new logger in ``state / logger.key`` and record ``days`` of history
    ending now; returns the bytes of record it holds then (``record status``). Module time
    is this computer's local time."""
    directory = state / logger.key
    load_identity(directory, Version.V2_10, logger.serial)
    start = time.time() - days * 86400
    virtual = VirtualLogger(
        database=directory / DATABASE_FILE,
        serial_number=logger.serial,
        site=state / f"{logger.key}.toml",
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
