"""Data cases of the bus part of a site file and of a board file: every mistake is named by
``FILE:LINE: field:`` exactly, a misspelt key or table with a "did you mean"; sensor sources
are a registry (a new kind is one registration, with its own keys)."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from sondalog.app.bus import start_bus_server
from sondalog.app.bus_build import build_bus
from sondalog.backends import sensor_sources
from sondalog.backends.linux import load_board
from sondalog.backends.sensor_bank import SensorBank
from sondalog.backends.sensor_sources import SourceKind
from sondalog.backends.sim.site_bus import load_bus_site
from sondalog.config import ConfigError, Table
from sondalog.hctmps1 import Kind
from sondalog.io.clock import RealClock

SITE = """\
[bus]
baud = 9600

[[bus.modules]]
id = "T1"
kind = "temp"
signal = { model = "constant", value = 20.0 }

[[bus.modules]]
id = "H1"
kind = "hum"
source = "iio:ads1115:1"
scale = 30.0
"""

BOARD = """\
[board]
hold = 60

[[board.ds18b20]]
pin = 4
master = "w1_bus_master1"

[board.rs485]
port = "/dev/ttyUSB0"
baud = 19200
"""


def _error(tmp_path: Path, text: str, load: object = load_bus_site) -> tuple[Path, str]:
    path = tmp_path / "site.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load(path)  # type: ignore[operator]
    return path, str(info.value)


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            'kind = "temp"',
            'kidn = "temp"',
            "6: bus.modules[0].kidn: unknown table or key 'kidn' (did you mean kind?",
        ),
        ("scale = 30.0", "scael = 30.0", "13: bus.modules[1].scael: unknown table or key 'scael'"),
        ("baud = 9600", "bauds = 9600", "2: bus.bauds: unknown table or key 'bauds' (did you mean"),
        (
            '[[bus.modules]]\nid = "H1"',
            '[[bus.module]]\nid = "H1"',
            "9: bus.module: unknown table or key 'module' (did you mean modules?",
        ),
        ("value = 20.0 }", "valeu = 20.0 }", "7: bus.modules[0].signal.valeu: unknown table"),
        ("baud = 9600", 'baud = "fast"', "2: bus.baud: must be a positive integer, not 'fast'"),
        (
            'id = "T1"',
            "id = 1",
            "5: bus.modules[0].id: must be 1 to 8 of A-Z a-z 0-9 _ -, not an integer",
        ),
        ("scale = 30.0", "scale = true", "13: bus.modules[1].scale: must be a number, not True"),
        (
            'source = "iio:ads1115:1"',
            'source = "i2c:0x40"',
            "12: bus.modules[1].source: 'i2c:0x40': expected w1:28-",
        ),
    ],
)
def test_bus_mistakes_name_file_line_and_field(
    tmp_path: Path, old: str, new: str, expected: str
) -> None:
    assert old in SITE
    path, message = _error(tmp_path, SITE.replace(old, new, 1))
    assert message.startswith(f"{path}:{expected}"), message


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            "hold = 60",
            "hodl = 60",
            "2: board.hodl: unknown table or key 'hodl' (did you mean hold?",
        ),
        (
            'master = "w1_bus_master1"',
            'mastr = "w1_bus_master1"',
            "6: board.ds18b20[0].mastr: unknown table or key 'mastr' (did you mean master?",
        ),
        ("[board.rs485]", "[board.rs458]", "8: board.rs458: unknown table or key 'rs458'"),
        ("hold = 60", 'hold = "60"', "2: board.hold: must be a number 1..86400, not '60'"),
        ("pin = 4", "pin = true", "5: board.ds18b20[0].pin: must be an integer 0..7, not True"),
        ("baud = 19200", "baud = 19200.5", "10: board.rs485.baud: must be an integer 300..4e+06"),
        ('port = "/dev/ttyUSB0"', "port = 0", "9: board.rs485.port: must be a non-empty string"),
    ],
)
def test_board_mistakes_name_file_line_and_field(
    tmp_path: Path, old: str, new: str, expected: str
) -> None:
    assert old in BOARD
    path, message = _error(tmp_path, BOARD.replace(old, new, 1), load_board)
    assert message.startswith(f"{path}:{expected}"), message


def test_a_board_file_holds_only_a_board(tmp_path: Path) -> None:
    (tmp_path / "pi.toml").write_text(BOARD + "\n[bord]\nhold = 1\n")
    site = tmp_path / "site.toml"
    site.write_text('board = "pi.toml"\n')
    with pytest.raises(ConfigError) as info:
        load_board(site)
    assert str(info.value).startswith(
        f"{tmp_path / 'pi.toml'}:12: bord: unknown table or key 'bord' (did you mean board?"
    )


@dataclass(frozen=True)
class _Fixed:
    value: float


class _FixedReader:
    def __init__(self, settings: _Fixed, root: Path) -> None:
        self.value = settings.value

    def read(self) -> float | None:
        return self.value


def _parse_fixed(address: str, module: Table, kind: Kind) -> _Fixed:
    return _Fixed(float(address) + module.number("bias", 0.0))


def test_a_new_sensor_source_is_one_registration(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sensor_sources, "_REGISTERED", {})  # (forgotten after the test)
    fixed = SourceKind(
        form="fixed:VALUE", parse=_parse_fixed, open=_FixedReader, keys=frozenset({"bias"})
    )
    sensor_sources.register("fixed", fixed)
    path = tmp_path / "site.toml"
    path.write_text(SITE.replace('"iio:ads1115:1"', '"fixed:1.5"\nbias = 0.1'))
    site = load_bus_site(path)
    source = site.modules[1].source
    assert source is not None and source.kind == "fixed"
    bank = SensorBank(tmp_path)
    bank.sensor(source)
    asyncio.run(bank.acquire())
    core, _ = build_bus(site, 0.0, sensors=bank)
    assert {a.module.module_id: a.module.value for a in core.modules}["H1"] == "48.0"
    path.write_text(SITE.replace('"iio:ads1115:1"', '"fixed:x"'))
    path_, message = _error(tmp_path, path.read_text())
    assert message.startswith(f"{path_}:12: bus.modules[1].source: 'fixed:x': could not convert")
    path_, message = _error(tmp_path, SITE.replace("scale = 30.0", "bias = 1"))
    assert "13: bus.modules[1].bias: unknown table or key" in message  # iio has no bias


def test_the_bus_site_does_not_import_the_linux_backend() -> None:
    code = (
        "import sys; from sondalog.backends.sim.site_bus import default_bus_site;"
        "default_bus_site();"
        "print([m for m in sys.modules if m.startswith('sondalog.backends.linux')])"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


def test_starting_consumes_the_plan_without_reading_the_file_again(tmp_path: Path) -> None:
    path = tmp_path / "site.toml"
    path.write_text(
        SITE.replace('source = "iio:ads1115:1"\nscale = 30.0\n', "cycle = 5\n").replace(
            'kind = "hum"',
            'kind = "hum"\nsignal = { model = "sine", mean = 50, amplitude = 5, period = 600 }',
        )
    )
    plan = load_bus_site(path)
    path.unlink()  # the plan is all the start needs

    async def go() -> None:
        clock = RealClock()
        running = await start_bus_server(clock, ("127.0.0.1", 0), site=plan)
        try:
            assert [a.module.module_id for a in running.core.modules] == ["T1", "H1"]
            assert running.core.baud == 9600
        finally:
            await running.close()

    asyncio.run(go())
