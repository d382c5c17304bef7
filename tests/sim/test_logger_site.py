"""The ``[logger]`` part of a site file: examples load, mistakes are named by file/line/field."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.ala1.hardware import rom_valid
from sondalog.backends.sim.logger_site import load_logger_site
from sondalog.backends.sim.site_bus import ConfigError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["logger-site.toml", "logger-replay.toml"])
def test_examples_load(name: str) -> None:
    hw = load_logger_site(EXAMPLES / name, 1e9)
    assert hw.analog, "every example wires at least one analog input"


def test_generated_rom_codes_are_valid_and_seeded() -> None:
    one = load_logger_site(EXAMPLES / "logger-site.toml", 1e9)
    two = load_logger_site(EXAMPLES / "logger-site.toml", 5e9)
    assert all(rom_valid(t.rom) for t in one.thermometers)
    assert [t.rom for t in one.thermometers] == [t.rom for t in two.thermometers]


BAD = [
    ("[logger]\nsupply = 12\n", 2, "logger.supply"),
    ("[logger]\ncolour = 'red'\n", 2, "logger.colour"),
    (
        "[logger]\n\n[[logger.analog]]\naddress = 16\nsignal = { model = 'constant', value = 1 }\n"
        "\n[[logger.analog]]\naddress = 21\nsignal = { model = 'constant', value = 1 }\n",
        8,
        "logger.analog[1].address",
    ),
    (
        "[logger]\n[[logger.ds18b20]]\npin = 4\nrom = '0000000000000028'\n"
        "signal = { model = 'constant', value = 1 }\n",
        4,
        "logger.ds18b20[0].rom",
    ),
    (
        "[logger]\n[[logger.ds18b20]]\npin = 9\nsignal = { model = 'constant', value = 1 }\n",
        3,
        "logger.ds18b20[0].pin",
    ),
    (
        "[logger]\n[[logger.pulses]]\ntimer = true\n",
        2,
        "logger.pulses[0]",
    ),
    (
        "[logger]\n[[logger.analog]]\naddress = 16\n"
        "signal = { model = 'sine', mean = 1, amplitude = 1, period = -5 }\n",
        4,
        "logger.analog[0].signal.period",
    ),
    ("[logger.gsm]\nsignal = { model = 'wobble' }\n", 2, "logger.gsm.signal.model"),
    ("[logger\n", None, "toml"),
]


@pytest.mark.parametrize(("text", "line", "field"), BAD)
def test_a_wrong_site_file_names_file_line_and_field(
    tmp_path: Path, text: str, line: int | None, field: str
) -> None:
    path = tmp_path / "site.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_logger_site(path, 1e9)
    message = str(info.value)
    assert message.startswith(f"{path}:{line}: " if line else f"{path}")
    assert field in message
    assert info.value.field == field


def test_a_missing_site_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_logger_site(tmp_path / "nope.toml", 1e9)
