"""The control API end to end: devices, inputs and time, observed by a client of the logger.

Every test serves a real site (TCP logger, HTTP control API) in its event loop; what the API
changes is observed the way a user's software sees it: a ``read`` over the logger's line.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

from control_site import START, Site, served

#: Channel 1: analog input 16 (volts); channel 2: the DS18B20 on pin 4; channel 3: the supply
#: (factory: behind output 1, the divider's switch); channel 4: pulses on the timer input.
SETUP = (
    "write date 20070301085959",
    "write channel max number 4",
    "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
    "write channel 1 format 0.2",
    "write device 2 type ds18b20 write device 2 address 4",
    "write channel 2 device 2 write channel 2 type 3 write channel 2 address 0",
    "write channel 2 switch output 0 write channel 2 format 0.2",
    "write device 3 type msp430ta",
    "write channel 4 device 3 write channel 4 type 6 write channel 4 switch output 0",
)


async def setup(site: Site) -> None:
    for line in SETUP:
        await site.ask(line)


async def read(site: Site, line: str) -> str:
    """``line``'s answer, stepping the clock a second at a time while the logger waits for
    a conversion or a switch advance (the clock is paused: nothing else moves it)."""
    task = asyncio.ensure_future(site.ask(line))
    for _ in range(60):
        done, _ = await asyncio.wait({task}, timeout=0.05)
        if done:
            return task.result()
        await site.post("/time/step", {"seconds": 1})
    return await task


def test_devices_and_their_inputs(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            devices = await site.get("/devices")
            assert [d["name"] for d in devices] == ["logger"]
            assert devices[0]["serial_number"] == "000001" and devices[0]["powered"]
            logger = await site.get("/devices/logger")
            inputs = logger["inputs"]
            assert inputs["supply"] == 12.0 and inputs["analog:16"] == 1.0
            assert inputs["pulses:timer"] == 2.0
            [rom] = [k for k in inputs if k.startswith("ds18b20:")]
            assert inputs[rom] == 21.5
            assert (await site.get("/health")) == {"ok": True, "devices": 1}

    asyncio.run(main())


def test_set_a_value_a_signal_model_and_a_pulse_rate(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            assert await read(site, "read channel 1 value") == "1.00"
            answer = await site.post("/devices/logger/set", {"input": "analog:16", "value": 1.25})
            assert answer["value"] == 1.25
            assert await read(site, "read channel 1 value") == "1.25"
            # a ramp from now: 0.5 V rising 0.001 V/s
            ramp = {"model": "ramp", "start": 0.5, "rate": 0.001}
            await site.post("/devices/logger/set", {"input": "analog:16", "signal": ramp})
            assert await read(site, "read channel 1 value") == "0.50"
            await site.post("/time/step", {"seconds": 1000})
            assert await read(site, "read channel 1 value") == "1.50"
            # the supply, read by channel 3
            await site.post("/devices/logger/set", {"input": "supply", "value": 13.8})
            assert await read(site, "read channel 3 value") == "13.8"
            # pulses: 5 per second over a minute of sampling
            await site.post("/devices/logger/set", {"input": "pulses:timer", "rate": 5})
            await site.ask("write channel 4 sampling period 000100")
            await site.ask("write channel 4 sampling start 20070301090000")
            await site.post("/time/step", {"seconds": 180})
            rows = (await site.ask("read record 10 from start")).splitlines()
            assert rows and all(r.split(",")[5] == "300.0" for r in rows), rows

    asyncio.run(main())


def test_pause_step_and_speed_are_seen_from_outside(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            clock = await site.get("/time")
            assert clock["paused"] and clock["now"] == START
            first = await site.ask("read date")
            await asyncio.sleep(1.1)
            assert await site.ask("read date") == first  # paused: time stands still
            # sampling each minute: a step of an hour takes 60 rows, all at once
            await site.ask("write channel 1 sampling period 000100")
            await site.ask("write channel 1 sampling start 20070301090000")
            assert await site.ask("read record 100 from start") == ""
            answer = await site.post("/time/step", {"seconds": 3600})
            assert answer["now"] == START + 3600
            assert await site.ask("read date") == "20070301095959"
            rows = (await site.ask("read record 100 from start")).splitlines()
            assert len(rows) == 60 and rows[-1].startswith("20070301095900.0,1,1.00")
            # run 1000 times real time: a real 0.3 s is about 5 minutes
            await site.post("/time/speed", {"factor": 1000})
            running = await site.post("/time/resume")
            assert not running["paused"] and running["speed"] == 1000
            await asyncio.sleep(0.3)
            stopped = await site.post("/time/pause")
            assert 200 < stopped["now"] - (START + 3600) < 3000
            more = (await site.ask("read record 100 from start")).splitlines()
            assert len(more) > 60

    asyncio.run(main())
