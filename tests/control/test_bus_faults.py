"""Faults of the RS-485 bus's HCTMPS1 modules over the control API (issue 23), observed by a
bus master on the bus's TCP port: a module taken off the bus answers nothing, a stuck one
keeps its value whatever its sensor does, and both come back when cleared."""

from __future__ import annotations

import asyncio
from pathlib import Path

from control_site import served

from sondalog.client.bus import BlockingBusMaster, BusMaster
from sondalog.testing.sites import BUS_SITE

SITE = BUS_SITE  # the plugin's own site: the same world


def test_bus_modules_disconnected_stuck_set_and_cleared(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path, SITE) as site:
            assert site.running.bus is not None
            host, port = site.running.bus.address
            url = f"tcp://{host}:{port}"

            def present() -> list[str]:
                # a scan, not one HELLO: two modules' random reply slots can collide
                # (CI saw both replies lost in one broadcast)
                with BlockingBusMaster(url) as bus:
                    return sorted(bus.run(lambda m: m.scan()))

            def pv(module: str) -> float:
                async def ask(master: BusMaster) -> float:
                    return await master.pv(module)

                with BlockingBusMaster(url) as bus:
                    return bus.run(ask)

            async def step(seconds: float) -> None:
                await site.post("/time/step", {"seconds": seconds})

            await site.post("/time/resume", {})  # (bytes take time on the line)
            assert [d["name"] for d in await site.get("/devices")] == ["bus"]
            described = await site.get("/devices/bus")
            assert described["inputs"] == {"module:T1": 21.0, "module:H1": 45.0}
            await site.post("/devices/bus/fault", {"kind": "disconnected", "input": "module:T1"})
            assert await asyncio.to_thread(present) == ["H1"]
            assert (await site.get("/devices/bus"))["inputs"]["module:T1"] is None
            await site.post("/devices/bus/clear", {"input": "module:T1"})
            assert await asyncio.to_thread(present) == ["H1", "T1"]
            # a new value shows after the module's next measurement
            await site.post("/devices/bus/set", {"input": "module:T1", "value": 30.5})
            await step(10)
            assert await asyncio.to_thread(pv, "T1") == 30.5
            # stuck: the sensor changes, the module's value does not
            await site.post("/devices/bus/fault", {"kind": "stuck", "input": "module:H1"})
            await site.post("/devices/bus/set", {"input": "module:H1", "value": 60.0}, 409)
            await step(10)
            assert await asyncio.to_thread(pv, "H1") == 45.0
            # a fault with a duration ends by itself within a step
            await site.post("/devices/bus/clear", {})
            body = {"kind": "disconnected", "input": "module:H1", "duration": 30}
            await site.post("/devices/bus/fault", body)
            await step(25)
            assert await asyncio.to_thread(present) == ["T1"]
            await step(5)
            assert await asyncio.to_thread(present) == ["H1", "T1"]
            # refusals
            await site.post("/devices/bus/fault", {"kind": "cut"}, 400)
            await site.post("/devices/bus/fault", {"kind": "stuck", "input": "module:X9"}, 404)
            await site.post("/devices/bus/fault", {"kind": "stuck", "input": "analog:16"}, 404)
            await site.post("/devices/bus/restart", {}, 409)

    asyncio.run(main())
