"""An example test suite of host software that talks to ALA1 loggers, using sondalog's
virtual devices as stand-ins (copy this folder, see README.md).

It imports nothing but ``sondalog.testing`` (the fixtures come from the plugin, registered
when sondalog is installed) and the sondalog client; your suite imports your own code where
this one calls the client directly.
"""

from __future__ import annotations

import pytest

from sondalog.client import Client
from sondalog.client.bus import BlockingBusMaster
from sondalog.client.phone import PhoneApi
from sondalog.testing import DeviceHandle, SiteFactory, SiteHandle

#: Channel 1 measures the analog input at address 16 (the fixture's site: 0.5, i.e. 500.00).
SETUP = [
    "write file record size 65536",
    "write channel max number 1",
    "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
    "write channel 1 cal2 mult 1000 write channel 1 format 0.2",
]


def configure(logger: Client) -> None:
    for line in SETUP:
        logger.command(line).raise_for_error()


def test_the_logger_answers(sondalog_logger: DeviceHandle) -> None:
    with Client(sondalog_logger.url) as logger:
        assert logger.command("read i version").lines == ("2.10",)
        assert logger.command("read i snumber", crcsum=True).lines == ("000001",)


def test_an_input_change_shows_in_the_reading(sondalog_logger: DeviceHandle) -> None:
    with Client(sondalog_logger.url) as logger:
        configure(logger)
        assert logger.command("read channel 1 value").lines == ("500.00",)
        sondalog_logger.set("analog:16", 0.8)
        reading = float(logger.command("read channel 1 value").lines[0])
    assert reading == pytest.approx(800, abs=0.5)  # the A/D converter's step


def test_six_hours_of_samples_in_no_time(sondalog_logger: DeviceHandle) -> None:
    with Client(sondalog_logger.url) as logger:
        configure(logger)
        logger.command("write channel 1 sampling period 0010").raise_for_error()
        sondalog_logger.step(hours=6)
        rows = logger.command("read record 100 from start").lines
    assert len(rows) == 37  # every 10 minutes from the start, both ends included
    assert rows[0] == "20000101000000.0,1,500.00"
    assert rows[-1] == "20000101060000.0,1,500.00"


def test_a_failing_sensor_and_a_power_cut(sondalog_logger: DeviceHandle) -> None:
    """What your software sees when the level sensor fails and the logger loses power."""
    with Client(sondalog_logger.url) as logger:
        configure(logger)
        logger.command("write channel 1 sampling period 0010").raise_for_error()
        sondalog_logger.fault("ch1", "disconnected")  # the input channel 1 reads (analog:16)
        assert logger.command("read channel 1 value").lines == ("",)  # no valid value
        sondalog_logger.step(hours=1)  # six samples without a value
        sondalog_logger.clear("ch1")
        sondalog_logger.fault("power_loss", duration=1800)  # back by itself after 30 minutes
        sondalog_logger.step(hours=1)
        rows = logger.command("read record 100 from start").lines
    times = [row[8:12] for row in rows]  # HHMM of YYYYMMDDHHMMSS.s
    values = [row.split(",")[2] for row in rows]
    assert values[1:7] == [""] * 6  # 00:10 ... 01:00
    assert times[7:] == ["0130", "0140", "0150", "0200"]  # nothing while there was no power
    assert values[-1] == "500.00"


def test_a_logger_served_as_a_process(sondalog_logger_process: DeviceHandle) -> None:
    sondalog_logger_process.snapshot("factory")  # (a session fixture would keep it)
    with Client(sondalog_logger_process.url) as logger:
        configure(logger)
        logger.command("write channel 1 sampling period 0010").raise_for_error()
        sondalog_logger_process.step(hours=1)  # through the control API of sondalog serve
        assert len(logger.command("read record 100 from start").lines) == 7
        sondalog_logger_process.restore("factory")  # a reset between tests, in milliseconds
        assert logger.command("read channel 1 sampling period").lines != ("0010",)


def test_the_bus_modules_answer(sondalog_bus: DeviceHandle) -> None:
    with BlockingBusMaster(sondalog_bus.url) as bus:
        # a window wider than the bus's own (16 slots): a CI machine under load answers late
        found = bus.run(lambda master: master.broadcast("HELLO", window=2.0))
    assert sorted(frame.src for frame in found) == ["H1", "T1"]


def test_the_gsm_world(sondalog_gsm: SiteHandle) -> None:
    numbers = {s["number"] for s in PhoneApi(sondalog_gsm.gsm.url).subscribers()}
    assert {"+420600000001", "+420700000001"} <= numbers
    with Client(sondalog_gsm.logger.url) as logger:
        assert logger.command("read i version").lines == ("2.10",)


def test_a_site_of_your_own(sondalog_site: SiteFactory) -> None:
    site = sondalog_site(
        """
        [logger]
        supply = { model = "constant", value = 11.2 }
        [logger.serve]
        listen = "127.0.0.1:0"
        serial_number = "CI-0001"
        """
    )
    with Client(site.logger.url) as logger:
        assert logger.command("read i snumber").lines == ("CI-0001",)
