"""Workflows of the bus master that the CLI offers (weewx's ``*_actions``: the work, not the
parsing): configure one module inside ``<connect>``, watch modules in autonomous mode
(hctmps1.md §3, §4)."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncGenerator, Sequence
from dataclasses import dataclass
from datetime import datetime

from sondalog.client.bus import BusMaster, DataFrame
from sondalog.client.bus_errors import BusError


class ConnectRefused(BusError):
    """CONNECT got no reply: a wrong password, a lockout, or no such module."""


@dataclass(frozen=True)
class ModuleSettings:
    """What :func:`configure_module` changes, in this order (§4)."""

    add_supervisors: Sequence[str] = ()
    delete_supervisors: Sequence[str] = ()
    symbol: str | None = None
    new_password: str | None = None
    new_id: str | None = None
    save: bool = False


async def configure_module(
    master: BusMaster, module_id: str, password: str, settings: ModuleSettings
) -> list[str]:
    """CONNECT, apply ``settings``, optionally SAVEEE, DISCONNECT; one report line a step."""
    if not await master.connect(module_id, password):
        raise ConnectRefused(
            f"{module_id}: CONNECT got no reply (wrong password, locked out or absent)"
        )
    lines = [f"CONNECT {module_id}: <OK>"]
    target = module_id

    def status(what: str, ok: bool) -> None:
        lines.append(f"{what}: {'<OK>' if ok else '<FA>'}")

    for supervisor in settings.add_supervisors:
        status(f"ADDSUP {supervisor}", await master.addsup(target, supervisor))
    for supervisor in settings.delete_supervisors:
        status(f"DELSUP {supervisor}", await master.delsup(target, supervisor))
    if settings.symbol is not None:
        status(f"ADDP {settings.symbol}", await master.addp(target, settings.symbol))
    if settings.new_password is not None:
        status("NEWPW", await master.newpw(target, settings.new_password))
    if settings.new_id is not None:
        ok = await master.setmid(target, settings.new_id)
        status(f"SETMID {settings.new_id}", ok)
        target = settings.new_id if ok else target
    if settings.save:
        await master.saveee(target)
        lines.append("SAVEEE: <OK>")
    await master.disconnect(target)
    lines.append(f"DISCONNECT {target}: <OK>")
    return lines


async def watch_modules(
    master: BusMaster, modules: Sequence[str], host_id: str
) -> AsyncGenerator[DataFrame, None]:
    """Put this host on each module's temporary list (CSSERVON), AUTOON, and yield data
    frames as REPLY grants bring them; stopping undoes both (AUTOOFF, CSSERVOFF)."""
    for target in modules:
        await master.csservon(target, host_id)
        await master.autoon(target)
    try:
        async for data in master.watch(modules):
            yield data
    finally:
        for target in modules:
            with contextlib.suppress(BusError):
                await master.autooff(target)
                await master.csservoff(target, host_id)


def format_data(data: DataFrame) -> str:
    """One data frame as a line: local ISO time, module, addressee, value."""
    stamp = datetime.fromtimestamp(data.received).astimezone().isoformat(timespec="milliseconds")
    return f"{stamp} {data.module} -> {data.addressee} {data.value}"
