"""``python -m sondalog.backends.linux BOARD``: read a board once and show what the logger sees."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from linux_fakesys import FakeIio, FakeW1

from sondalog.backends.linux.__main__ import main

BOARD = """\
[board]
[[board.ds18b20]]
pin = 4
master = "w1_bus_master1"

[[board.analog]]
address = 16
iio = "ads1115"
channel = 0

[board.supply]
iio = "ads1115"
channel = 3
gain = 11.0
"""


def test_check_shows_rom_codes_volts_and_supply(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    w1 = FakeW1(tmp_path, bulk=False)
    w1.sensor("28-000008d5e4fd", 21.5)
    w1.sensor("28-0000055a1b2c", 85.0)
    iio = FakeIio(tmp_path)
    iio.raw(0, 12000)
    iio.raw(3, 8727)
    (tmp_path / "board.toml").write_text(BOARD)
    assert main([str(tmp_path / "board.toml"), "--root", str(tmp_path)]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "ds18b20 P6.4 28-0000055a1b2c = 2F0000055A1B2C28: no valid value",
        "ds18b20 P6.4 28-000008d5e4fd = 46000008D5E4FD28: 21.5000 °C",
        "analog 16: 0.6000 of the reference (1.5000 V int. ref)",
        "supply: 12.00 V",
    ]


def test_a_wrong_board_exits_2_naming_the_line(tmp_path: Path) -> None:
    (tmp_path / "board.toml").write_text(BOARD.replace("pin = 4", "pin = 12"))
    done = subprocess.run(
        [sys.executable, "-m", "sondalog.backends.linux", str(tmp_path / "board.toml")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert f"{tmp_path / 'board.toml'}:3: board.ds18b20[0].pin: must be an integer 0..7" in (
        done.stderr
    )
