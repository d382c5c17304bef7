"""The Python control hook of the simulation (docs/simulation.md)."""

from __future__ import annotations

from pathlib import Path

from sondalog.app.virtual import VirtualLogger

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_drive_a_logger_from_python() -> None:
    logger = VirtualLogger(site=EXAMPLES / "logger-site.toml")
    assert logger.command("write date 20070301090000") == "OK\r\n"
    assert logger.command("read channel 1 value") == "12.4\r\nOK\r\n"  # waits for the switch
    logger.command("write channel 1 sampling period 000100")
    logger.command("write channel 1 sampling start 20070301090100")
    logger.command("write channel 1 record change 0")
    logger.step(3 * 60)
    assert logger.command("read record status") == "75,0.00,FILLING\r\nOK\r\n"  # 3 x 25
    logger.set_signal("supply", 11.0)
    logger.step(60)
    last = logger.command("read record 1 from date/20070301090400/")
    assert last == "20070301090400.0,1,11.0\r\nOK\r\n"
    logger.close()


def test_ds18b20_by_rom_code_from_the_example_site() -> None:
    logger = VirtualLogger(site=EXAMPLES / "logger-site.toml")
    logger.command("write device 3 type ds18b20")
    logger.command("write device 3 address 4")
    logger.command("write channel 1 device 3")
    logger.command("write channel 1 type 3")
    logger.command("write channel 1 switch output 0")
    logger.command("write channel 1 address x 47123456789ABC28")
    value = float(logger.command("read channel 1 value").split("\r\n")[0])
    assert 12.0 <= value <= 24.0  # sine 18 +- 6 degrees
