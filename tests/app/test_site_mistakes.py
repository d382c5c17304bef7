"""One case per mistake a site file can hold (issue 25 item 1, Telegraf style): each is
refused by ``load_site`` with the exact ``FILE:LINE: field:`` prefix and a clear message;
the backend registry plans a logger's and a fleet's hardware."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from sondalog.ala1.hardware import NoHardware
from sondalog.app.fleet import start_fleet
from sondalog.app.site import load_site
from sondalog.backends import registry
from sondalog.backends.registry import BackendContext
from sondalog.config import ConfigError, Table
from sondalog.io.clock import RealClock

LOGGER = '[logger]\nseed = 7\n\n[logger.serve]\nlisten = "127.0.0.1:0"\n'
FLEET = '[[loggers]]\nserial_number = "A1"\nlisten = "127.0.0.1:0"\n'
SIGNAL = 'signal = { model = "constant", value = 1.0 }\n'

#: (name, file text, line, field, words of the message)
MISTAKES = [
    ("misspelt [loger]", "[loger]\nseed = 7\n", 1, "loger", "did you mean logger?"),
    ("misspelt [bsu]", "[bsu]\nbaud = 9600\n", 1, "bsu", "did you mean bus?"),
    ("a [fleet] table", "[fleet]\ncount = 3\n", 1, "fleet", "unknown table or key 'fleet'"),
    ("misspelt top-level key", 'bord = "board.toml"\n' + LOGGER, 1, "bord", "did you mean board?"),
    ("unknown key in [logger]", "[logger]\nsede = 7\n", 2, "logger.sede", "did you mean seed?"),
    (
        "unknown key in [[logger.analog]]",
        LOGGER + "\n[[logger.analog]]\nadress = 16\n" + SIGNAL,
        8,
        "logger.analog[0].adress",
        "did you mean address?",
    ),
    (
        "unknown key in [logger.serve]",
        LOGGER + 'protocl = "2.10"\n',
        6,
        "logger.serve.protocl",
        "did you mean protocol?",
    ),
    (
        "unknown key in a signal",
        LOGGER + '\n[logger.gsm]\nsignal = { model = "constant", valu = 3 }\n',
        8,
        "logger.gsm.signal.valu",
        "unknown table or key 'valu'",
    ),
    (
        "unknown key in [[loggers]]",
        FLEET + 'lisen = "127.0.0.1:0"\n',
        4,
        "loggers[0].lisen",
        "did you mean listen?",
    ),
    (
        "unknown key in [bus.serve]",
        '[bus]\nbaud = 9600\n\n[bus.serve]\nlistne = "127.0.0.1:0"\n',
        5,
        "bus.serve.listne",
        "did you mean listen?",
    ),
    ("seed = true", "[logger]\nseed = true\n", 2, "logger.seed", "must be an integer 0.."),
    (
        "supply_power = 1.5",
        "[logger]\nsupply_power = 1.5\n",
        2,
        "logger.supply_power",
        "must be an integer 1..7, not 1.5",
    ),
    (
        "external_reference = true",
        "[logger]\nexternal_reference = true\n",
        2,
        "logger.external_reference",
        "must be volts > 0, not True",
    ),
    (
        "timer = 1",
        "[logger]\n[[logger.pulses]]\ntimer = 1\nrate = 2.0\n",
        3,
        "logger.pulses[0].timer",
        "must be true or false, not 1",
    ),
    (
        "poisson = 3",
        "[logger]\n[[logger.pulses]]\ntimer = true\npoisson = 3\n",
        4,
        "logger.pulses[0].poisson",
        "must be a table, not an integer",
    ),
    (
        'line_rate = "yes"',
        LOGGER + 'line_rate = "yes"\n',
        6,
        "logger.serve.line_rate",
        "must be true or false, not 'yes'",
    ),
    (
        "listen = 10001",
        "[logger]\n[logger.serve]\nlisten = 10001\n",
        3,
        "logger.serve.listen",
        'must be "HOST:PORT", not an integer',
    ),
    ("backend = 5", "[logger]\nbackend = 5\n", 2, "logger.backend", "must be a string"),
    (
        "an unknown backend",
        '[logger]\nbackend = "nowhere"\n',
        2,
        "logger.backend",
        "no hardware backend 'nowhere'",
    ),
    (
        "count = true",
        FLEET.replace('"A1"', '"A{n}"') + "count = true\n",
        4,
        "loggers[0].count",
        "must be an integer from 1 to 20000, not True",
    ),
    (
        "a fleet on one board",
        FLEET + 'backend = "linux"\n',
        4,
        "loggers[0].backend",
        "cannot serve a fleet",
    ),
    (
        "a fleet on an unknown backend",
        FLEET + 'backend = "nowhere"\n',
        4,
        "loggers[0].backend",
        "no hardware backend 'nowhere'",
    ),
    (
        "delay_before_tx = true",
        '[bus]\n[[bus.modules]]\nid = "T1"\nkind = "temp"\n'
        + SIGNAL
        + '[bus.serve]\nserial = "/dev/ttyUSB9"\nrs485 = "rts"\ndelay_before_tx = true\n',
        9,
        "bus.serve.delay_before_tx",
        "must be seconds, not True",
    ),
]


@pytest.mark.parametrize(
    ("text", "line", "field", "words"), [m[1:] for m in MISTAKES], ids=[m[0] for m in MISTAKES]
)
def test_each_mistake_is_refused_at_its_file_line_and_field(
    tmp_path: Path, text: str, line: int, field: str, words: str
) -> None:
    site = tmp_path / "site.toml"
    site.write_text(text)
    with pytest.raises(ConfigError) as caught:
        load_site(site)
    assert str(caught.value).startswith(f"{site}:{line}: {field}: "), str(caught.value)
    assert words in str(caught.value)


def test_a_mistake_in_a_fleet_world_names_the_world_file(tmp_path: Path) -> None:
    world = tmp_path / "station.toml"
    world.write_text("[logger]\nsupply_powr = 2\n")
    site = tmp_path / "fleet.toml"
    site.write_text(FLEET + 'site = "station.toml"\n')
    with pytest.raises(ConfigError) as caught:
        load_site(site)
    assert str(caught.value).startswith(f"{world}:2: logger.supply_powr: ")
    assert "did you mean supply_power?" in str(caught.value)


def test_a_world_for_another_backend_is_refused(tmp_path: Path) -> None:
    (tmp_path / "station.toml").write_text('[logger]\nbackend = "linux"\n')
    site = tmp_path / "fleet.toml"
    site.write_text(FLEET + 'site = "station.toml"\n')
    with pytest.raises(ConfigError, match=r"station.toml:2: logger.backend: names 'linux'"):
        load_site(site)


def test_the_logger_hardware_is_planned_at_load_and_built_at_start(tmp_path: Path) -> None:
    """The plan holds the parsed [logger]; building it twice gives two hardwares."""
    site = tmp_path / "site.toml"
    site.write_text(LOGGER + "\n[[logger.analog]]\naddress = 16\n" + SIGNAL)
    plan = load_site(site)
    assert plan.logger is not None and plan.logger.backend == "sim"
    one, two = plan.logger.hardware.build(1e9), plan.logger.hardware.build(2e9)
    assert one is not two
    assert one.adc(0, 16, 1e9) == two.adc(0, 16, 2e9)


def test_a_fleet_builds_each_logger_through_the_registry(tmp_path: Path) -> None:
    """A plug-in backend with its own [logger] keys serves a fleet: planned once at load,
    built once per logger at start."""
    built: list[BackendContext] = []

    def plan(logger: Table) -> float:
        return logger.keys(("backend", "gain")).number("gain")

    def create(context: BackendContext) -> NoHardware:
        built.append(context)
        return NoHardware()

    registry.register("test-fleet", create, plan=plan)
    (tmp_path / "world.toml").write_text("[logger]\ngain = 2.5\n")
    site = tmp_path / "fleet.toml"
    site.write_text(
        '[[loggers]]\ncount = 2\nserial_number = "P{n}"\nlisten = "127.0.0.1:0"\n'
        'backend = "test-fleet"\nsite = "world.toml"\n'
    )
    plan_ = load_site(site)
    assert built == []

    async def run() -> None:
        fleet = await start_fleet(plan_.fleet, tmp_path / "state", RealClock(), site)
        await fleet.close()

    asyncio.run(run())
    assert [c.plan for c in built] == [2.5, 2.5]
    assert all(c.path == tmp_path / "world.toml" for c in built)
