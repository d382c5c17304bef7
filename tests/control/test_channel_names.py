"""``ch2``: a fault or a value given to the input a logger's channel reads (issue 23's
``logger.fault("ch2", "disconnected")``), resolved from the channel's configuration now."""

from __future__ import annotations

import asyncio
from pathlib import Path

from control_site import served
from test_inputs_time import read, setup


def test_a_channel_names_the_input_it_reads(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)  # 1: analog 16, 2: the DS18B20 on pin 4, 4: the timer's pulses
            answer = await site.post(
                "/devices/logger/fault", {"kind": "disconnected", "input": "ch1"}
            )
            assert answer["fault"]["input"] == "analog:16"
            assert await read(site, "read channel 1 value") == ""
            cleared = await site.post("/devices/logger/clear", {"input": "ch1"})
            assert [f["input"] for f in cleared["cleared"]] == ["analog:16"]
            assert await read(site, "read channel 1 value") == "1.00"
            answer = await site.post(
                "/devices/logger/fault", {"kind": "power_on_reset", "input": "ch2"}
            )
            assert answer["fault"]["input"].startswith("ds18b20:")
            assert await read(site, "read channel 2 value") == "85.00"
            await site.post("/devices/logger/clear", {})
            answer = await site.post("/devices/logger/set", {"input": "ch4", "rate": 5})
            assert answer["input"] == "pulses:timer" and answer["value"] == 5.0
            # what the channel's input cannot take, a channel that is not there
            bad = await site.post("/devices/logger/fault", {"kind": "bad_crc", "input": "ch1"}, 400)
            assert bad["field"] == "input" and "ch1 reads analog:16" in bad["error"]
            await site.post("/devices/logger/set", {"input": "ch4", "value": 1}, 400)
            await site.post("/devices/logger/set", {"input": "ch1", "rate": 1}, 400)
            missing = await site.post(
                "/devices/logger/fault", {"kind": "stuck", "input": "ch9"}, 404
            )
            assert "no channel 9" in missing["error"]
            # the channel is read as configured now
            await site.ask("write channel 1 address 17")
            answer = await site.post(
                "/devices/logger/fault", {"kind": "stuck", "input": "ch1"}, 404
            )
            assert "analog:17" in answer["error"]

    asyncio.run(main())
