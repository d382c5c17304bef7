"""1-Wire DS18B20 through the kernel's w1 sysfs (§6.4.3.1, §6.4.3.1.1)."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from linux_fakesys import FakeW1, w1_slave_text

from sondalog.ala1.hardware import rom_code, rom_valid
from sondalog.backends.linux.w1 import (
    W1Master,
    millis_to_celsius,
    parse_w1_slave,
    rom_from_slave,
    slave_from_rom,
)


def test_maxim_published_rom_example() -> None:
    """Maxim AN27's example ROM, sent on the wire as 02 1C B8 01 00 00 00 A2: the kernel
    names it 02-00000001b81c, the logger writes it A20000001B81C02 (family lowest, CRC highest)."""
    assert rom_from_slave("02-00000001b81c") == 0xA2000000_01B81C02
    assert slave_from_rom(0xA2000000_01B81C02) == "02-00000001b81c"


def test_mapping_both_ways_matches_the_cores_rom_codes() -> None:
    rng = random.Random(5)
    for _ in range(200):
        serial = rng.randrange(2**48)
        name = f"28-{serial:012x}"
        rom = rom_from_slave(name)
        assert rom == rom_code(serial) and rom_valid(rom)
        assert rom & 0xFF == 0x28 and (rom >> 8) & (2**48 - 1) == serial
        assert slave_from_rom(rom) == name


def test_a_wrong_crc_byte_is_refused() -> None:
    rom = rom_from_slave("28-000008d5e4fd")
    with pytest.raises(ValueError, match="CRC"):
        slave_from_rom(rom ^ (1 << 60))
    with pytest.raises(ValueError):
        rom_from_slave("28-xyz")


def test_w1_slave_parsing() -> None:
    assert parse_w1_slave(w1_slave_text(23.125)) == 23.125
    assert parse_w1_slave(w1_slave_text(-10.125)) == -10.125
    assert parse_w1_slave(w1_slave_text(23.125, crc_ok=False)) is None  # kernel says NO
    assert parse_w1_slave(w1_slave_text(85.0)) is None  # power-on value
    bad = w1_slave_text(20.0).replace("4b 46", "4b 47")  # scratchpad inconsistent with its CRC
    assert parse_w1_slave(bad) is None
    assert parse_w1_slave("") is None
    zeros = "00 00 00 00 00 00 00 00 00 : crc=00 YES\n00 00 00 00 00 00 00 00 00 t=0\n"
    assert parse_w1_slave(zeros) is None  # a bus without pull-up reads all zeros


def test_millidegrees_snap_to_the_sensors_grid() -> None:
    assert millis_to_celsius(23062) == 23.0625  # the kernel truncates 23.0625 to 23062
    assert millis_to_celsius(85000) is None
    assert millis_to_celsius(200000) is None


def test_master_lists_reads_and_triggers(tmp_path: Path) -> None:
    w1 = FakeW1(tmp_path)
    w1.sensor("28-000008d5e4fd", 21.5)
    w1.sensor("28-0000055a1b2c", 4.25, modern=False)  # an old kernel: only w1_slave
    (w1.path / "10-000001234567").mkdir()  # a DS18S20: another family, not ours
    (w1.path / "w1_master_slaves").write_text("28-000008d5e4fd\n")
    master = W1Master(w1.path)
    assert master.slaves() == ["28-0000055a1b2c", "28-000008d5e4fd"]
    assert master.read("28-000008d5e4fd") == 21.5
    assert master.read("28-0000055a1b2c") == 4.25
    assert master.read("28-000000000001") is None  # gone
    assert master.has_bulk and master.trigger()
    assert w1.bulk_text == "trigger\n"
    assert not master.converting()
    (w1.path / "therm_bulk_read").write_text("-1\n")
    assert master.converting()
    assert not W1Master(FakeW1(tmp_path, "w1_bus_master2", bulk=False).path).trigger()
