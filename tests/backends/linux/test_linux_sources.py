"""Real sensors behind HCTMPS1 modules (backends/linux/sources.py, registered in
backends/sensor_sources.py) on fake sysfs trees, and the site-file parts that choose them:
``source``, ``[bus.serve] rs485``, ``[board.rs485]``."""

from __future__ import annotations

import asyncio
import os
import tty
from pathlib import Path

import pytest
from linux_fakesys import FakeIio, FakeW1

from sondalog.app.bus_build import build_bus
from sondalog.app.site import load_site
from sondalog.backends.linux.rs485 import BusTiming, Rs485Settings
from sondalog.backends.linux.sources import IioSource, W1Source
from sondalog.backends.sensor_bank import HeldSensor, NoReading, SensorBank
from sondalog.backends.sensor_sources import SourcePlan, open_source, read_source
from sondalog.backends.sim.site_bus import load_bus_site
from sondalog.client.bus_links import (
    BusUrlError,
    Rs485Link,
    inter_frame_gap,
    open_link,
    parse_bus_url,
)
from sondalog.config import ConfigError, of
from sondalog.hctmps1 import Kind, encode_frame

SLAVE = "28-000008d5e4fd"


def parse_source(text: str, scale: float = 1.0, offset: float = 0.0) -> SourcePlan:
    """The plan of a module table holding ``source = text`` (a temperature module)."""
    return read_source(of({"source": text, "scale": scale, "offset": offset}), Kind.TEMP)


def test_source_forms() -> None:
    w1 = parse_source(f"w1:{SLAVE}")
    assert (w1.kind, w1.settings) == ("w1", W1Source(SLAVE))
    iio = parse_source("iio:iio:device0:3", 31.25, -23.8)
    assert (iio.kind, iio.settings, iio.scale, iio.offset) == (
        "iio", IioSource("iio:device0", 3), 31.25, -23.8
    )  # fmt: skip
    assert parse_source("iio:ads1115:1").settings == IioSource("ads1115", 1)
    for bad in ("w1:10-000008d5e4fd", "w1:28-xyz", "i2c:0x40", "iio:ads1115", "adc0"):
        with pytest.raises(ConfigError, match="source: '"):
            parse_source(bad)


def test_a_ds18b20_source_holds_its_last_valid_reading(tmp_path: Path) -> None:
    w1 = FakeW1(tmp_path, bulk=False)
    w1.sensor(SLAVE, 21.125, modern=False)  # only w1_slave: CRC checked, t= parsed
    now = [100.0]
    plan = parse_source(f"w1:{SLAVE}")
    held = HeldSensor(plan, open_source(plan, tmp_path), hold=30, host_now=lambda: now[0])
    with pytest.raises(NoReading):
        held(0.0)  # never read
    held.store(held.read())
    assert held(0.0) == 21.125
    w1.set(SLAVE, 85.0)  # the power-on value: no valid reading, the last one is held
    held.store(held.read())
    now[0] += 29
    assert held(0.0) == 21.125
    now[0] += 2  # older than the hold: gone
    with pytest.raises(NoReading):
        held(0.0)
    w1.remove(SLAVE)
    assert held.read() is None


def test_a_humidity_source_scales_an_iio_channel(tmp_path: Path) -> None:
    iio = FakeIio(tmp_path, 0, "ads1115", scale=0.125)  # mV per count
    iio.raw(1, 16000)  # 2.0 V
    bank = SensorBank(tmp_path)
    held = bank.sensor(parse_source("iio:ads1115:1", 30.0, -10.0))
    assert bank.sensor(parse_source("iio:ads1115:1", 30.0, -10.0)) is held  # one per source
    asyncio.run(bank.acquire())
    assert held(0.0) == pytest.approx(50.0)  # 2.0 V * 30 %/V - 10 %


SITE = """
[bus]
baud = 9600

[[bus.modules]]
id = "H1"
kind = "hum"
source = "iio:ads1115:1"
scale = 30.0
offset = -10.0

[[bus.modules]]
id = "T1"
kind = "temp"
source = "w1:28-000008d5e4fd"
"""


def test_modules_measure_their_sources_from_power_up(tmp_path: Path) -> None:
    iio = FakeIio(tmp_path, 0, "ads1115", scale=0.125)
    iio.raw(1, 14000)  # 1.75 V -> 42.5 %RH
    FakeW1(tmp_path, bulk=False).sensor(SLAVE, -3.5)
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    bus_site = load_bus_site(site)
    bank = SensorBank(tmp_path)
    for entry in bus_site.modules:
        assert entry.source is not None
        bank.sensor(entry.source)
    asyncio.run(bank.acquire())
    core, _ = build_bus(bus_site, 0.0, sensors=bank)
    values = {a.module.module_id: a.module.value for a in core.modules}
    assert values == {"H1": "42.5", "T1": "-3.50"}  # the variants' formats (hctmps1.md §1)
    with pytest.raises(ValueError, match="SensorBank"):
        build_bus(bus_site, 0.0)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('source = "iio:ads1115:1"', f'source = "w1:{SLAVE}"', "DS18B20 measures temperature"),
        ('source = "iio:ads1115:1"', 'source = "adc0"', "expected w1:28-"),
        ("scale = 30.0", 'scale = "x"', "scale: must be a number"),
    ],
)
def test_bad_sources_name_the_field(tmp_path: Path, old: str, new: str, message: str) -> None:
    site = tmp_path / "site.toml"
    site.write_text(SITE.replace(old, new))
    with pytest.raises(ConfigError, match=r"bus\.modules\[0\]") as caught:
        load_bus_site(site)
    assert message in str(caught.value)


def test_a_signal_and_a_source_together_are_refused(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(SITE + 'signal = { model = "constant", value = 1.0 }\n')
    with pytest.raises(ConfigError, match=r"signal or a source, not both"):
        load_bus_site(site)


def _plan_error(tmp_path: Path, serve: str) -> str:
    site = tmp_path / "site.toml"
    site.write_text(SITE + "\n[bus.serve]\n" + serve + "\n")
    with pytest.raises(ConfigError) as caught:
        load_site(site)
    return str(caught.value)


def test_bus_serve_rs485_options_are_checked(tmp_path: Path) -> None:
    assert "an RS-485 mode needs the adapter" in _plan_error(tmp_path, 'rs485 = "auto"')
    assert "must be one of kernel, rts, auto" in _plan_error(
        tmp_path, 'serial = "/dev/ttyUSB0"\nrs485 = "magic"'
    )
    assert "turnaround" in _plan_error(
        tmp_path, 'serial = "/dev/ttyUSB0"\nrs485 = "rts"\ndelay_before_rx = 0.01'
    )
    assert "need an RS-485 mode" in _plan_error(tmp_path, "delay_before_tx = 0.001")
    site = tmp_path / "site.toml"
    site.write_text(
        SITE + '\n[bus.serve]\nserial = "/dev/ttyUSB0"\nrs485 = "rts"\ndelay_before_tx = 0.001\n'
    )
    bus = load_site(site).bus
    assert bus is not None and bus.serial == "/dev/ttyUSB0"
    assert bus.rs485 == Rs485Settings("rts", 0.001, 0.0)


def test_the_board_files_rs485_adapter_serves_the_bus(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(
        SITE.replace("baud = 9600\n", "")
        + '\n[board]\n[board.rs485]\nport = "/dev/ttyAMA0"\nbaud = 19200\nmode = "kernel"\n'
    )
    bus = load_site(site).bus
    assert bus is not None
    assert (bus.serial, bus.rs485, bus.baud) == ("/dev/ttyAMA0", Rs485Settings("kernel"), 19200)


def test_bus_urls_with_an_rs485_mode() -> None:
    url = parse_bus_url("serial:///dev/ttyUSB0?baud=19200&rs485=rts")
    assert (url.device, url.baud, url.rs485) == ("/dev/ttyUSB0", 19200, "rts")
    assert parse_bus_url("serial:///dev/ttyUSB0").rs485 is None
    with pytest.raises(BusUrlError, match="rs485 must be one of kernel, rts, auto"):
        parse_bus_url("serial:///dev/ttyUSB0?rs485=half")
    for baud in (1200, 9600, 115200):  # the master keeps the bus timing of the modules' side
        assert inter_frame_gap(baud) == pytest.approx(BusTiming(baud).inter_frame_gap)


def test_the_masters_rs485_link_keeps_the_inter_frame_gap() -> None:
    master_fd, slave_fd = os.openpty()
    tty.setraw(slave_fd)
    name = os.ttyname(slave_fd)
    frame = encode_frame("T1", "PC", "PV")

    async def go() -> float:
        link = await open_link(f"serial://{name}?baud=9600&rs485=auto")
        assert isinstance(link, Rs485Link)
        try:
            loop = asyncio.get_running_loop()
            start = loop.time()
            await link.send(frame)
            await link.send(frame)  # waits for the first frame, then the gap
            elapsed = loop.time() - start
            os.write(master_fd, b":PC,T1,RPV.21.50|0000\r\n")
            assert await link.receive() == b":PC,T1,RPV.21.50|0000\r\n"
        finally:
            await link.close()
        with pytest.raises(OSError, match="no RTS line"):
            await open_link(f"serial://{name}?rs485=rts")
        return elapsed

    try:
        elapsed = asyncio.run(go())
        got = b""
        while len(got) < 2 * len(frame):
            got += os.read(master_fd, 256)
        assert got == frame * 2
        assert elapsed >= len(frame) * 10 / 9600 + inter_frame_gap(9600)
    finally:
        os.close(slave_fd)
        os.close(master_fd)
