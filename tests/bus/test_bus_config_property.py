"""The round trip over random valid configurations (issue 22), in virtual time.

A bus is configured by hand with the module's own commands (CONNECT, ADDSUP, ADDP,
SETMID, SAVEEE, AUTOON); its settings are pulled into a file; the file (with ``was`` for a
renamed module) is applied to a factory-fresh bus; pulling that bus gives the same file, and
every module answers LISTSUP, LISTP and GETMODE as the hand-configured one does.
"""

from __future__ import annotations

import string

from bus_helpers import make_module, run_virtual, start_bus
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client.bus import BusMaster
from sondalog.client.bus_config import ModuleState, read_settings, render
from sondalog.client.bus_config_run import apply, plan, pull
from sondalog.config import loads
from sondalog.world.bus import BusCore

_ID = st.text(string.ascii_letters + string.digits + "_-", min_size=1, max_size=8)
_SYMBOL = st.text(string.ascii_letters + string.digits + "_", min_size=1, max_size=8)


@st.composite
def _wanted(draw: st.DrawFn, factory: str, taken: str) -> ModuleState:
    address = draw(_ID.filter(lambda a: a != taken))
    return ModuleState(
        address,
        None,
        tuple(draw(st.lists(_ID, max_size=8, unique=True))),
        draw(st.none() | _SYMBOL),
        draw(st.booleans()),
    )


def _bus() -> BusCore:
    core = BusCore(9600)
    core.add_module(make_module("T1", seed=1))
    core.add_module(make_module("H1", seed=2, humidity=True))
    return core


async def _by_hand(master: BusMaster, at: str, want: ModuleState) -> None:
    assert await master.connect(at, "0000")
    for sup in want.supervisors:
        assert await master.addsup(at, sup)
    if want.symbol is not None:
        assert await master.addp(at, want.symbol)
    if want.address != at:
        assert await master.setmid(at, want.address)
    await master.saveee(want.address)
    await master.disconnect(want.address)
    if want.autonomous:
        await master.autoon(want.address)


async def _answers(master: BusMaster, address: str) -> tuple[list[str], str | None, bool]:
    assert await master.connect(address, "0000")
    answers = (await master.listsup(address), await master.listp(address))
    await master.disconnect(address)
    return (*answers, await master.getmode(address))


@settings(max_examples=25, deadline=None)
@given(_wanted("T1", "H1"), st.data())
def test_pull_apply_to_a_factory_bus_pull_again_is_identical(
    t: ModuleState, data: st.DataObject
) -> None:
    h = data.draw(_wanted("H1", t.address))

    async def main() -> None:
        field, spare = await start_bus(_bus()), await start_bus(_bus())
        async with BusMaster(field.link()) as a, BusMaster(spare.link()) as b:
            await _by_hand(a, "T1", t)
            await _by_hand(a, "H1", h)
            pulled = render(await pull(a, [t.address, h.address]))
            text = pulled
            for factory, want in (("T1", t), ("H1", h)):
                if want.address != factory:
                    line = f'address = "{want.address}"'
                    text = text.replace(line, f'{line}\nwas = "{factory}"', 1)
            file = read_settings(loads(text))
            reports = await apply(b, await plan(b, file, "0000"), "0000")
            assert all(r.failure is None for r in reports), reports
            assert render(await pull(b, [t.address, h.address])) == pulled
            for address in (t.address, h.address):
                mine, theirs = await _answers(a, address), await _answers(b, address)
                assert mine[1:] == theirs[1:] and set(mine[0]) == set(theirs[0])
                assert mine[0] == theirs[0]  # applied in the file's order: the same order
            assert all(not mp.changes for mp in await plan(b, file, "0000"))
        await field.stop()
        await spare.stop()

    run_virtual(main)
