"""Costs of the linux backend's hot paths on fake kernel trees (no board needed).

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_linux_backend.py``.

- cached reads: ``adc`` / ``ds18b20`` / ``supply`` as the core calls them at a sample.
- pulses: edge events taken into the counter and windows counted (a 50 Hz anemometer-like
  input over an hour).
- acquisition pass: one ``acquire()`` (in a fresh ``asyncio.run``) over sysfs-like files in
  a temporary directory (8 thermometers without a bulk conversion, 4 IIO channels): the
  file I/O and worker-thread overhead that a real board adds to the sensors' own
  conversion times.
"""

from __future__ import annotations

import asyncio
import tempfile
import time
import tomllib
from pathlib import Path

from sondalog.ala1.hardware import dallas_crc8
from sondalog.backends.linux import parse_board
from sondalog.backends.linux.fakegpio import FakeChip
from sondalog.backends.linux.gpio import Edge, PulseCounter
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.backends.linux.w1 import rom_from_slave

BOARD = """\
[board]
[[board.ds18b20]]
pin = 4
master = "w1_bus_master1"
[board.supply]
iio = "adc"
channel = 3
gain = 11.0
""" + "".join(
    f'[[board.analog]]\naddress = {16 + i}\niio = "adc"\nchannel = {i}\n' for i in range(3)
)


def tree(root: Path) -> None:
    master = root / "sys/bus/w1/devices/w1_bus_master1"
    for i in range(8):
        slave = master / f"28-{i + 1:012x}"
        slave.mkdir(parents=True)
        body = (300 + i).to_bytes(2, "little") + bytes([0x4B, 0x46, 0x7F, 0xFF, 0x0C, 0x10])
        pad = " ".join(f"{b:02x}" for b in body + bytes([dallas_crc8(body)]))
        (slave / "w1_slave").write_text(f"{pad} : crc=00 YES\n{pad} t={(300 + i) * 62}\n")
        (slave / "temperature").write_text(f"{(300 + i) * 62}\n")
    dev = root / "sys/bus/iio/devices/iio:device0"
    dev.mkdir(parents=True)
    (dev / "name").write_text("adc\n")
    (dev / "in_voltage_scale").write_text("0.125\n")
    for ch in range(4):
        (dev / f"in_voltage{ch}_raw").write_text("8000\n")


def rate(label: str, n: int, seconds: float, unit: str = "calls") -> None:
    print(f"{label:<44} {n / seconds:>12,.0f} {unit}/s  ({seconds / n * 1e6:8.2f} us each)")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        tree(root)
        now = 1e9
        hw = LinuxHardware(
            parse_board(tomllib.loads(BOARD)),
            root=root,
            chips={"gpiochip0": FakeChip()},
            host_now=lambda: now,
        )
        passes = 20
        t = time.perf_counter()
        for _ in range(passes):
            asyncio.run(hw.acquire())
        rate("acquisition pass (8 DS18B20 + 4 IIO)", passes, time.perf_counter() - t, "passes")
        rom = rom_from_slave("28-000000000001")
        assert hw.ds18b20(4, rom, now) is not None and hw.adc(1, 16, now) is not None
        n = 100_000
        t = time.perf_counter()
        for _ in range(n):
            hw.adc(1, 16, now)
            hw.ds18b20(4, rom, now)
            hw.supply(now)
        rate("cached reads (adc + ds18b20 + supply)", n, time.perf_counter() - t)

    clock = [0.0]
    counter = PulseCounter(lambda: clock[0])
    counter.watch(17)
    hour = 3600 * 50
    edges = [Edge(17, int(i * 20e6), False) for i in range(hour)]
    t = time.perf_counter()
    for start in range(0, hour, 500):  # the loop reads events in batches of 10 s
        clock[0] = (start + 500) * 0.02
        counter.take(edges[start : start + 500], int(clock[0] * 1e9))
    rate("pulse events taken (50 Hz, 1 h)", hour, time.perf_counter() - t, "events")
    t = time.perf_counter()
    windows = 10_000
    total = sum(counter.count(17, k * 0.36, (k + 1) * 0.36) for k in range(windows))
    rate("windows counted", windows, time.perf_counter() - t, "windows")
    assert total == hour, total


if __name__ == "__main__":
    main()
