"""A logger whose com line drives a GSM modem restarts, loses power and is restored like any
other (issue 23): its new engine drives the same modem on the same line, which the network
sees as the logger's modem set up again."""

from __future__ import annotations

import asyncio
from pathlib import Path

from control_site import http, served

from sondalog.testing.sites import GSM_SITE

SITE = GSM_SITE  # the plugin's own site: the same world


def test_a_logger_driving_a_modem_restarts_and_drives_it_again(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path, SITE) as site:
            assert site.running.gsm_api is not None
            api = site.running.gsm_api.address[1]
            logger = site.running.logger
            assert logger is not None
            for _ in range(30):  # the driver sets the modem up (second by second: AT timeouts)
                await site.post("/time/step", {"seconds": 1})
            engine = site.control.control.logger("logger").engine
            line = engine.modem.line if engine.modem is not None else None
            await site.post("/devices/logger/snapshot", {"name": "up"})
            assert (await site.post("/devices/logger/restart", {}))["restarts"] == 1
            await site.post("/devices/logger/fault", {"kind": "power_loss", "duration": 60})
            for _ in range(90):
                await site.post("/time/step", {"seconds": 1})
            await site.post("/devices/logger/restore", {"name": "up"})
            engine = site.control.control.logger("logger").engine
            assert engine.modem is not None and engine.modem.line == line
            assert await site.ask("read i version") == "2.10"
            assert (await site.get("/devices/logger"))["restarts"] == 3
            for _ in range(30):
                await site.post("/time/step", {"seconds": 1})
            status, subscribers = await http(api, "GET", "/subscribers")
            modem = next(s for s in subscribers if s["number"] == "+420600000001")
            assert status == 200 and modem["registered"] and modem["radio"]

    asyncio.run(main())
