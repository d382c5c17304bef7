"""The bus master against a virtual bus in the same process, on virtual time."""

from __future__ import annotations

import asyncio

import pytest
from bus_helpers import START, make_module, ramp, run_virtual, start_bus

from sondalog.client.bus import BusMaster
from sondalog.client.bus_errors import NoReply
from sondalog.hctmps1 import encode_frame
from sondalog.io.clock import SteppedClock
from sondalog.io.host import DeviceHost
from sondalog.world.bus import DEFAULT_TURNAROUND, BusCore


def test_scan_finds_ten_modules_despite_collisions() -> None:
    async def main() -> tuple[dict[str, str], int]:
        core = BusCore(9600)
        for i in range(10):
            core.add_module(make_module(f"M{i}", seed=100 + i, humidity=i % 2 == 1))
        bus = await start_bus(core)
        async with BusMaster(bus.link()) as master:
            found = await master.scan()
        await bus.stop()
        return found, core.medium.collisions

    found, collisions = run_virtual(main)
    assert sorted(found) == [f"M{i}" for i in range(10)]
    assert found["M0"] == "HCTMPS1-temp server (DS18B20)"
    assert found["M1"] == "HCTMPS1-hum server (SHT11)"
    assert collisions > 0  # the scan had to work through collisions


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_scan_is_complete_for_other_seeds(seed: int) -> None:
    async def main() -> dict[str, str]:
        core = BusCore(9600)
        for i in range(10):
            core.add_module(make_module(f"S{i}", seed=seed * 1000 + i))
        bus = await start_bus(core)
        async with BusMaster(bus.link()) as master:
            found = await master.scan()
        await bus.stop()
        return found

    assert len(run_virtual(main)) == 10


def test_polling_32_modules_collects_every_queued_frame_exactly_once() -> None:
    cycles = 5

    async def main() -> tuple[dict[str, list[str]], dict[str, list[str]]]:
        core = BusCore(9600)
        ids = [f"N{i:02d}" for i in range(32)]
        for i, mid in enumerate(ids):
            core.add_module(make_module(mid, seed=i, signal=ramp(0.1 + i / 100)))
        bus = await start_bus(core)
        expected: dict[str, list[str]] = {mid: [] for mid in ids}
        async with BusMaster(bus.link()) as master:
            for mid in ids:
                assert await master.csservon(mid, "PC")
                assert await master.csservon(mid, "LOG1")
                await master.autoon(mid)
            # Let each module run `cycles` measurement cycles, recording what it queues.
            await asyncio.sleep(cycles * 10.0)
            for mid in ids:
                await master.autooff(mid)
                module = core.module(mid)
                expected[mid] = [q.body[len("RPV.") :] for q in module.queue]
            frames = await master.poll(ids)
            assert all(not core.module(mid).queue for mid in ids)
        await bus.stop()
        got: dict[str, list[str]] = {mid: [] for mid in ids}
        for frame in frames:
            got[frame.module].append(frame.value)
        return expected, got

    expected, got = run_virtual(main)
    for mid, values in expected.items():
        assert len(values) >= 2 * (cycles - 1)
        assert got[mid] == values, mid


def test_typed_helpers_round_trip() -> None:
    async def main() -> None:
        core = BusCore(9600)
        core.add_module(make_module("T1", seed=1))
        core.add_module(make_module("H1", seed=2, humidity=True, signal=lambda t: 48.5))
        bus = await start_bus(core)
        async with BusMaster(bus.link(), "HOST") as m:
            assert await m.hello("H1") == "HCTMPS1-hum server (SHT11)"
            assert await m.getver("T1") == "HVER*1_00*V-2013.SVER*1_1*VI-2018"
            assert await m.pv("T1") == 21.5
            assert await m.pv_text("H1") == "48.5"
            assert not await m.connect("T1", "wrong")
            assert await m.connect("T1", "0000")
            assert await m.addsup("T1", "L1")
            assert not await m.addsup("T1", "bad id!")
            assert await m.listsup("T1") == ["L1"]
            assert await m.delsup("T1", "L1")
            assert await m.listsup("T1") == []
            assert await m.addp("T1", "TEMP1")
            assert await m.listp("T1") == "TEMP1"
            assert await m.delp("T1", "TEMP1")
            assert await m.listp("T1") is None
            assert await m.newpw("T1", "pw2")
            await m.saveee("T1")
            await m.resee("T1")
            await m.reinit("T1")
            assert await m.csservon("T1", "HOST")
            assert await m.csservlist("T1") == ["HOST"]
            assert await m.reply("T1") is None
            assert await m.pv("T1") == 21.5
            data = await m.reply("T1")
            assert data is not None and (data.module, data.addressee, data.value) == (
                "T1",
                "HOST",
                "21.50",
            )
            assert await m.csservoff("T1", "HOST")
            await m.autoon("T1")
            assert await m.getmode("T1")
            await m.autooff("T1")
            assert not await m.getmode("T1")
            assert await m.setmid("T1", "T5")
            assert await m.hello("T5") == "HCTMPS1-temp server (DS18B20)"
            await m.disconnect("T5")
            with pytest.raises(NoReply):
                await m.listsup("T5")
            assert not await m.connect("T5", "0000")  # the saved password is pw2
            assert await m.connect("T5", "pw2")
        await bus.stop()

    run_virtual(main)


def test_retries_recover_from_a_lost_reply() -> None:
    async def main() -> tuple[str, int]:
        core = BusCore(9600)
        core.add_module(make_module("T1", seed=1))
        bus = await start_bus(core)
        jammer = bus.link()
        request = encode_frame("T1", "PC", "HELLO")
        # Another node talks over the module's first answer; the retry gets through.
        reply_starts = len(request) * 10 / 9600 + DEFAULT_TURNAROUND
        loop = asyncio.get_running_loop()
        loop.call_later(reply_starts + 0.005, jammer.write, b"\x00" * 8)
        async with BusMaster(bus.link()) as master:
            text = await master.hello("T1")
        await bus.stop()
        return text, core.medium.collisions

    text, collisions = run_virtual(main)
    assert text == "HCTMPS1-temp server (DS18B20)"
    assert collisions == 1


def test_noise_on_the_line_is_survived_with_retries() -> None:
    async def main() -> list[float]:
        core = BusCore(9600, bit_error_rate=2e-4)
        core.add_module(make_module("T1", seed=1))
        bus = await start_bus(core)
        async with BusMaster(bus.link(), retries=5) as master:
            values = [await master.pv("T1") for _ in range(50)]
        await bus.stop()
        assert core.medium.bit_errors > 0
        return values

    assert run_virtual(main) == [21.5] * 50


def test_bus_runs_on_a_stepped_clock() -> None:
    async def main() -> None:
        clock = SteppedClock(START)
        core = BusCore(9600)
        core.add_module(make_module("T1", seed=1))
        bus = DeviceHost(core, clock)
        bus.start()
        chunks: list[bytes] = []
        port = bus.link(chunks.append)
        port.write(encode_frame("*", "PC", "HELLO"))
        for _ in range(20):
            await asyncio.sleep(0)
        assert chunks == []  # nothing happens until the clock moves
        for _ in range(200):
            clock.advance(0.01)
            for _ in range(5):
                await asyncio.sleep(0)
        assert b"".join(chunks) == encode_frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
        await bus.stop()

    asyncio.run(main())
