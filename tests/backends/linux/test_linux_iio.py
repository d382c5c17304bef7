"""A/D inputs through IIO sysfs: volts = (raw + offset) * scale / 1000, normalised (§6.5.5)."""

from __future__ import annotations

from pathlib import Path

import pytest
from linux_fakesys import FakeIio

from sondalog.backends.linux.iio import IioChannel, IioError, find_device, normalise


def test_shared_scale_and_per_channel_offset(tmp_path: Path) -> None:
    dev = FakeIio(tmp_path, 0, "ads1115", scale=0.125)  # 0.125 mV per count
    dev.raw(0, 8000)
    dev.raw(1, 100)
    dev.attribute("in_voltage1_offset", -20)
    dev.attribute("in_voltage1_scale", 2.0)  # a channel's own scale wins over the shared one
    assert IioChannel(dev.path, 0).volts() == pytest.approx(1.0)
    assert IioChannel(dev.path, 1).volts() == pytest.approx(0.16)


def test_device_by_name_or_number(tmp_path: Path) -> None:
    FakeIio(tmp_path, 0, "mcp3008")
    ads = FakeIio(tmp_path, 1, "ads1115")
    assert find_device(tmp_path, "ads1115") == ads.path
    assert find_device(tmp_path, "iio:device1") == ads.path
    with pytest.raises(IioError, match="no IIO device named 'ads1015'"):
        find_device(tmp_path, "ads1015")
    with pytest.raises(IioError, match="iio:device7"):
        find_device(tmp_path, "iio:device7")
    FakeIio(tmp_path, 2, "ads1115")
    with pytest.raises(IioError, match="several"):
        find_device(tmp_path, "ads1115")
    with pytest.raises(IioError, match="in_voltage5_raw"):
        IioChannel(ads.path, 5)


def test_a_failed_read_is_no_value(tmp_path: Path) -> None:
    dev = FakeIio(tmp_path)
    dev.raw(0, 10)
    channel = IioChannel(dev.path, 0)
    (dev.path / "in_voltage0_raw").write_text("busy\n")
    assert channel.volts() is None


def test_normalise_is_the_12_bit_fraction_of_the_reference() -> None:
    assert normalise(1.25) == pytest.approx(round(0.5 * 4095) / 4095)
    assert normalise(3.0) == 1.0  # saturates at the reference
    assert normalise(-0.1) == 0.0
    assert normalise(1.0, reference=2.0) == pytest.approx(round(0.5 * 4095) / 4095)
