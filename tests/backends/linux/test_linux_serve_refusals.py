"""What a user trying the linux backend trips over (issue 26): ``--speed`` with real sensors
and GPIO parts without the ``gpiod`` bindings are refused with exit 2 and a message saying
what to do, not a board that silently reads nothing or a traceback."""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner
from linux_fakesys import FakeW1

from sondalog.app.logger import logger_hardware
from sondalog.app.serve import start_site
from sondalog.app.site import load_site
from sondalog.backends.linux.__main__ import main as check_board
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.cli.main import cli
from sondalog.config import ConfigError
from sondalog.io.clock import AcceleratedClock, Clock

SENSOR = "28-000008d5e4fd"
SITE = """\
[logger]
backend = "linux"

[logger.serve]
listen = "127.0.0.1:0"

[board]
[[board.ds18b20]]
pin = 4
master = "w1_bus_master1"
"""
GPIO = """
[[board.outputs]]
output = 2
chip = "gpiochip0"
line = 27
"""


@pytest.fixture
def site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    root = tmp_path / "root"
    FakeW1(root).sensor(SENSOR, 21.5)
    monkeypatch.setenv("SONDALOG_ROOT", str(root))
    path = tmp_path / "site.toml"
    path.write_text(SITE)
    return path


def test_speed_is_refused_with_a_real_board(site: Path) -> None:
    """Under --speed the core asks for readings at accelerated times that the cache, filled
    in real time, never holds: every channel would read "no valid value" for good."""
    with pytest.raises(ConfigError) as info:  # sondalog serve SITE --speed 10
        asyncio.run(_start(site, AcceleratedClock(10.0)))
    assert str(info.value).startswith(f"{site}:2: logger.backend: --speed 10: ")
    assert "keep real time" in str(info.value)
    with pytest.raises(ConfigError, match="--speed 600: "):  # sondalog logger serve --site
        logger_hardware(site, time.time(), 600.0)
    hardware = logger_hardware(site, time.time(), 1.0)
    assert isinstance(hardware, LinuxHardware)
    hardware.close()


async def _start(site: Path, clock: Clock) -> None:
    running = await start_site(load_site(site), site.parent / "state", clock)
    await running.close()


def test_gpio_parts_without_the_bindings_name_the_install_line(
    site: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    site.write_text(SITE + GPIO)
    monkeypatch.setitem(sys.modules, "gpiod", None)  # `import gpiod` fails as when missing
    result = CliRunner().invoke(cli, ["serve", str(site), "--state", str(site.parent / "st")])
    assert result.exit_code == 2, result.output
    assert f"{site}:14: board.outputs[0].chip: GPIO needs the gpiod bindings" in result.output
    assert "pip install 'sondalog[linux]'" in result.output
    assert check_board([str(site), "--root", str(site.parent / "root")]) == 2
