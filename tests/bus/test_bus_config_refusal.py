"""A module that refuses a write in the middle of ``bus config apply`` (issue 22).

The virtual module never refuses a value the file's checks let through, so this bus is
served in-process (real TCP, the real runtime) with one change to its T1: an older firmware
whose supervisor list holds only 2 IDs, so its third ``ADDSUP`` answers ``<FA>``. The
apply must stop at that setting, say why, give the module back its saved settings with
``REINIT``, report what was not applied, and still apply the other module of the file.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from sondalog.app.bus import start_bus_server
from sondalog.client.bus import BusMaster
from sondalog.client.bus_config import ModuleState, read_settings
from sondalog.client.bus_config_run import ModuleReport, apply, plan, read_module
from sondalog.client.bus_errors import NoReply
from sondalog.config import loads
from sondalog.hctmps1 import module as core
from sondalog.io.clock import RealClock

FILE = """\
[[module]]
address = "T5"
was = "T1"
symbol = "S1"
supervisors = ["A", "B", "C"]

[[module]]
address = "H1"
symbol = "H"
"""


def _small_list(monkeypatch: pytest.MonkeyPatch) -> None:
    needs_connect, addsup = core._COMMANDS["ADDSUP"]

    def older_firmware(
        module: core.Hctmps1Module, requester: str, param: str | None, now: float
    ) -> str | None:
        if module.config.factory_id == "T1" and len(module.settings.supervisors) >= 2:
            return core.FA
        return addsup(module, requester, param, now)

    monkeypatch.setitem(core._COMMANDS, "ADDSUP", (needs_connect, older_firmware))


def test_a_refused_write_stops_the_module_and_rolls_it_back(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _small_list(monkeypatch)

    async def main() -> tuple[list[ModuleReport], ModuleState, ModuleState, bool]:
        server = await start_bus_server(RealClock(), ("127.0.0.1", 0), state_dir=tmp_path)
        master = await BusMaster.open(f"tcp://127.0.0.1:{server.address[1]}")
        try:
            plans = await plan(master, read_settings(loads(FILE, tmp_path / "m.toml")), "0000")
            assert [str(c) for c in plans[0].changes] == [
                "symbol: (none) -> S1",
                "supervisors: (none) -> A, B, C",
                "address: T1 -> T5",
            ]
            reports = await apply(master, plans, "0000")
            t1 = await read_module(master, "T1")
            h1 = await read_module(master, "H1")
            try:
                await master.hello("T5")
                renamed = True
            except NoReply:
                renamed = False
            return reports, t1, h1, renamed
        finally:
            await master.close()
            await server.close()

    reports, t1, h1, renamed = asyncio.run(main())
    refused, other = reports
    assert refused.status == "failed"
    assert refused.failure == (
        "supervisors: ADDSUP C answered <FA>: bad format or no room left in the supervisor list"
        " (Tabela 1 ADDSUP)"
    )
    assert [c.setting for c in refused.not_applied] == ["symbol", "supervisors", "address"]
    assert refused.applied == []
    assert "nothing saved: REINIT restored the saved settings" in refused.notes
    # REINIT gave back the saved (factory) settings: not even the symbol written before stays.
    assert t1 == ModuleState("T1", "temp", (), None, False)
    assert not renamed  # the address change, last, was never sent
    # The other module of the file is applied all the same.
    assert other.status == "changed" and h1.symbol == "H"
