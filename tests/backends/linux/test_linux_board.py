"""The board file: the example loads; mistakes are named by file, line and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.backends.linux import load_board
from sondalog.config import ConfigError

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"


def test_the_raspberry_pi_example_loads() -> None:
    board = load_board(EXAMPLES / "board-raspberrypi.toml")
    assert board is not None
    assert [w.master for w in board.ds18b20] == ["w1_bus_master1"]
    assert board.analog[0].address == 16 and board.analog[0].power == 2
    assert board.supply is not None and board.supply.gain == 11.0
    assert board.pulses[0].timer and board.pulses[0].edge == "falling"
    assert board.outputs[0].active_low
    assert board.serial == ("/dev/serial0",)


def test_a_site_file_names_its_board_file(tmp_path: Path) -> None:
    (tmp_path / "pi.toml").write_text('[board]\n[[board.ds18b20]]\npin = 2\nmaster = "m"\n')
    site = tmp_path / "site.toml"
    site.write_text('board = "pi.toml"\n\n[logger]\nseed = 1\n')
    board = load_board(site)
    assert board is not None and board.ds18b20[0].pin == 2
    assert board.path == tmp_path / "pi.toml"
    site.write_text("[logger]\nseed = 1\n")
    assert load_board(site) is None


BAD = [
    ("[board]\ncolour = 1\n", 2, "board.colour", "unknown table or key"),
    ("[board]\nbackend = 'sim'\n", 2, "board.backend", "for 'linux'"),
    ("[board]\n\n[[board.ds18b20]]\npin = 9\nmaster = 'w1_bus_master1'\n", 4, "pin", "0..7"),
    (
        "[board]\n[[board.ds18b20]]\npin = 1\nmaster = 'a'\n[[board.ds18b20]]\npin = 1\n"
        "master = 'b'\n",
        6,
        "board.ds18b20[1].pin",
        "already wired",
    ),
    ("[board]\n[[board.analog]]\naddress = 21\niio = 'x'\nchannel = 0\n", 3, "address", "ADC"),
    ("[board]\n[[board.analog]]\naddress = 16\niio = 'x'\n", 2, "channel", "required"),
    (
        "[board]\n[[board.pulses]]\ntimer = true\nchip = 'gpiochip0'\nline = 17\nedge = 'up'\n",
        6,
        "board.pulses[0].edge",
        "rising",
    ),
    (
        "[board]\n[[board.outputs]]\noutput = 2\nchip = 'c'\nline = 5\n[[board.pulses]]\n"
        "address = 17\nchip = 'c'\nline = 5\n",
        5,
        "board.outputs[0].line",
        "c line 5 is used by board.pulses[0]",
    ),
    ("[board]\n[[board.outputs]]\noutput = 8\nchip = 'c'\nline = 5\n", 3, "output", "1..7"),
    ("[board.rs485]\nport = '/dev/ttyUSB0'\ndelay_before_rx = 0.01\n", 3, "delay", "turnaround"),
    ("[board.rs485]\nport = '/dev/ttyUSB0'\nmode = 'magic'\n", 3, "board.rs485.mode", "kernel"),
    ("[board.serial]\nports = '/dev/ttyS0'\n", 2, "board.serial.ports", "list"),
    # an unknown part is named at its own table, not at [board] (issue 26)
    (
        "[board]\nhold = 60\n\n[[board.ds18b20]]\npin = 4\nmaster = 'w1_bus_master1'\n\n"
        "[[board.dht22]]\npin = 17\n",
        8,
        "board.dht22",
        "unknown table or key",
    ),
    ("[board]\nhold = 60\n\n[board.dht22]\npin = 17\n", 4, "board.dht22", "unknown table or key"),
]


@pytest.mark.parametrize(("text", "line", "field", "message"), BAD)
def test_mistakes_name_file_line_and_field(
    tmp_path: Path, text: str, line: int, field: str, message: str
) -> None:
    path = tmp_path / "site.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_board(path)
    assert info.value.line == line, str(info.value)
    assert field in info.value.field and message in str(info.value)
    assert str(info.value).startswith(f"{path}:{line}: ")


def test_an_unreadable_board_file(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text('board = "missing.toml"\n')
    with pytest.raises(ConfigError, match=r"site\.toml:1: board: .*missing\.toml: cannot read"):
        load_board(site)
