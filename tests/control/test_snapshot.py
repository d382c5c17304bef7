"""Snapshot and restore of a logger's whole state, a fleet's loggers, and /openapi.json."""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

from control_site import SITE, http, served
from test_inputs_time import read, setup

from sondalog.ala1.record import RecordMemory
from sondalog.app.control_api import DEVICE_ACTIONS, TIME_ACTIONS
from sondalog.app.control_snapshot import read_state, write_state
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.backends.store.record_pages import write_record


def test_restore_puts_back_memory_record_and_inputs(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            await setup(site)
            await site.ask("write channel 1 sampling period 000100")
            await site.ask("write channel 1 sampling start 20070301090000")
            await site.post("/time/step", {"seconds": 300})
            record = await site.ask("read record 100 from start")
            answer = await site.post("/devices/logger/snapshot", {"name": "clean"})
            assert answer["record_rows"] == 5
            # a test changes everything
            await site.ask("write channel 1 sampling period 000010")
            await site.ask("write i description dirty")
            await site.post("/devices/logger/set", {"input": "analog:16", "value": 2.0})
            await site.post("/time/step", {"seconds": 300})
            await site.ask("write record type linear")
            assert await site.ask("read record 100 from start") != record
            await site.post("/devices/logger/fault", {"kind": "cut"})
            # restore: the faults end, the memory, the record and the inputs are as kept
            answer = await site.post("/devices/logger/restore", {"name": "clean"})
            assert answer["record_rows"] == 5
            assert await site.ask("read record 100 from start") == record
            assert await site.ask("read channel 1 sampling period") == "000100"
            assert await site.ask("read i description") == "000001"
            assert await read(site, "read channel 1 value") == "1.00"
            device = await site.get("/devices/logger")
            assert device["faults"] == [] and device["snapshots"] == ["clean"]
            # the module clock runs on from the host's time (battery-backed)
            assert await site.ask("read date") == "20070301090959"
            # a snapshot can be restored again and again
            await site.post("/time/step", {"seconds": 120})
            await site.post("/devices/logger/restore", {"name": "clean"})
            assert await site.ask("read record 100 from start") == record

    asyncio.run(main())


def test_write_state_after_a_branch_writes_the_rows_that_differ(tmp_path: Path) -> None:
    """Restoring A, writing new rows, then restoring B: B's rows, not a mix of both."""
    database = NvDatabase(tmp_path / "nv.sqlite")
    store = database.store("L1")
    conn = database.conn

    def record(*rows: str, first: int = 1) -> RecordMemory:
        """The rows on disk and the engine's copy of them."""
        write_record(conn, "L1", first, rows)
        return RecordMemory(list(rows), first, 10**6, True)

    def on_disk() -> list[tuple[int, str]]:
        return conn.execute(
            "SELECT seq, row FROM record WHERE logger = 'L1' ORDER BY seq"
        ).fetchall()

    full = read_state(store, record("a", "b", "c", "d"))
    short = read_state(store, record("a", "b"))
    write_state(store, short, record("a", "b", "c", "d"))
    assert on_disk() == [(1, "a"), (2, "b")]
    write_state(store, full, record("a", "b", "X"))  # a new branch after restoring the short
    assert on_disk() == [(1, "a"), (2, "b"), (3, "c"), (4, "d")]
    write_state(store, full, record("c", "d", "e", "f", first=3))  # a cyclic record moved on
    assert on_disk() == [(1, "a"), (2, "b"), (3, "c"), (4, "d")]
    write_state(store, short, record(first=9))  # cleared
    assert on_disk() == [(1, "a"), (2, "b")]
    database.close()


def test_a_fleets_loggers_are_devices_too(tmp_path: Path) -> None:
    async def main() -> None:
        text = SITE + '\n[[loggers]]\nserial_number = "F-1"\nlisten = "127.0.0.1:0"\n'
        async with served(tmp_path, text) as site:
            names = [d["name"] for d in await site.get("/devices")]
            assert names == ["logger", "loggers.F-1"]
            member = site.running.fleet.members[0]
            host, port = member.server.address
            await site.post("/devices/loggers.F-1/snapshot", {})
            await site.post("/devices/loggers.F-1/fault", {"kind": "power_loss"})
            assert [d["powered"] for d in await site.get("/devices")] == [True, False]
            await site.post("/devices/loggers.F-1/clear", {})
            await site.post("/devices/loggers.F-1/restore", {})
            reader, writer = await asyncio.open_connection(host, port)
            writer.write(b"read i snumber\r")
            assert await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 5) == b"F-1\r\nOK\r\n"
            writer.close()

    asyncio.run(main())


def test_openapi_describes_every_route(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            spec = await site.get("/openapi.json")
            assert spec["openapi"].startswith("3.1")
            paths = set(spec["paths"])
            wanted = {"/health", "/openapi.json", "/devices", "/devices/{name}", "/time"}
            wanted |= {f"/devices/{{name}}/{a}" for a in DEVICE_ACTIONS}
            wanted |= {f"/time/{a}" for a in TIME_ACTIONS}
            assert paths == wanted
            # every schema a path names exists
            refs = set(re.findall(r'"#/components/schemas/(\w+)"', str(spec).replace("'", '"')))
            assert refs <= set(spec["components"]["schemas"])
            fault = spec["components"]["schemas"]["Fault"]
            assert "noise" in fault["properties"]["kind"]["enum"]
            status, _ = await http(site.port, "GET", "/nowhere")
            assert status == 404

    asyncio.run(main())
