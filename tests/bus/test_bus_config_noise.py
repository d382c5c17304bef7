"""``bus config apply`` on a noisy line, in virtual time (issue 22; DESIGN.md point 8).

Lost and garbled replies make the master resend writes: a second ``DELSUP`` answers
``<FA>``, a second ``SETMID`` nothing (the module already answers at its new ID). Apply
reads such a write back before calling it refused. Over many noise seeds: apply ends within
a bounded (virtual) time, and each module either holds the file's settings afterwards
(a plan on a clean line finds nothing to change) or was reported failed and holds its old
settings whole (REINIT gave them back).
"""

from __future__ import annotations

import asyncio
import random

from bus_helpers import make_module, run_virtual, start_bus
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client.bus import BusMaster
from sondalog.client.bus_config import ModuleState, read_settings
from sondalog.client.bus_config_run import ModuleReport, apply, plan, read_module
from sondalog.config import loads
from sondalog.world.bus import BusCore

FILE = """\
[[module]]
address = "T5"
was = "T1"
symbol = "S1"
supervisors = ["C", "D"]
autonomous = true

[[module]]
address = "H1"
symbol = "H"
"""
BEFORE = ModuleState("T1", "temp", ("A", "B", "C"), "OLD", False)
WANTED = ModuleState("T5", "temp", ("C", "D"), "S1", True)
#: Every wait of the master is bounded: 2 modules, some 40 requests, 6 tries of ~0.52 s.
BOUND = 40 * 6 * 0.6


async def _prepare(master: BusMaster) -> None:
    assert await master.connect("T1", "0000")
    for sup in BEFORE.supervisors:
        assert await master.addsup("T1", sup)
    assert await master.addp("T1", "OLD")
    await master.saveee("T1")
    await master.disconnect("T1")


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1e-4, 3e-4, 6e-4]))
def test_apply_on_a_noisy_line_converges_or_fails_whole(seed: int, rate: float) -> None:
    async def main() -> tuple[list[ModuleReport], float, list[int], ModuleState]:
        core = BusCore(9600, rng=random.Random(seed))
        core.add_module(make_module("T1", seed=seed))
        core.add_module(make_module("H1", seed=seed + 1, humidity=True))
        bus = await start_bus(core)
        loop = asyncio.get_running_loop()
        file = read_settings(loads(FILE))
        async with BusMaster(bus.link(), retries=5) as master:
            await _prepare(master)
            core.medium.bit_error_rate = rate
            start = loop.time()
            reports = await apply(master, await plan(master, file, "0000"), "0000")
            elapsed = loop.time() - start
            core.medium.bit_error_rate = 0.0
            after = [len(mp.changes) for mp in await plan(master, file, "0000")]
            t = reports[0]
            state = await read_module(master, "T1" if t.status == "failed" else "T5")
        await bus.stop()
        return reports, elapsed, after, state

    reports, elapsed, after, t_state = run_virtual(main)
    assert elapsed < BOUND  # live: every wait has its deadline
    for report, left in zip(reports, after, strict=True):
        if report.status != "failed":
            assert left == 0, report
    t_report = reports[0]
    if t_report.status == "failed":
        # Nothing saved; REINIT gave the RAM back (autonomous mode, RAM, comes after saving).
        assert (t_state.supervisors, t_state.symbol) == (BEFORE.supervisors, BEFORE.symbol)
    else:
        assert t_state == WANTED
