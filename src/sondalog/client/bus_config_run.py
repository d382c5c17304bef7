"""Pull, plan and apply HCTMPS1 modules' settings over the bus (issue 22; Tabela 1).

Every setting but autonomous mode needs the ``<connect>`` context (``CONNECT`` with the
module's password); autonomous mode is RAM and needs none. :func:`read_module` reads what a
module holds (``HELLO``, ``LISTSUP``, ``LISTP``, ``GETMODE``); :func:`plan` finds each module
of a file (at its address, else at its ``was``) and what would change; :func:`apply_module`
writes only the differences in an order the module accepts (symbol, supervisors with the
deletions first, password, the address last), reads each one back, then ``SAVEEE``, and
checks the EEPROM by ``REINIT`` and reading everything again at the module's new address.
A refusal (``<FA>``, no reply, a value read back that differs) stops the module: ``REINIT``
gives back its saved settings, and the report says which setting failed, why, and what was
and was not applied. Another module of the file is still applied.
"""

from __future__ import annotations

import contextlib
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field

from sondalog.client.bus import BusMaster
from sondalog.client.bus_actions import ConnectRefused
from sondalog.client.bus_config import (
    Change,
    ModuleEntry,
    ModuleState,
    SettingsFile,
    differences,
    show_ids,
)
from sondalog.client.bus_errors import BusError, ForeignPeer, NoReply
from sondalog.protocol.hctmps1_settings import FACTORY_PASSWORD, HELLO_TEXTS, variant_of

#: Why a command answers ``<FA>`` (Tabela 1, "w sytuacji błędnej").
REFUSALS = {
    "SETMID": "the module refuses the ID (bad command, Tabela 1 SETMID)",
    "ADDSUP": "bad format or no room left in the supervisor list (Tabela 1 ADDSUP)",
    "DELSUP": "the ID is not in the supervisor list (Tabela 1 DELSUP)",
    "ADDP": "bad format of the symbol (Tabela 1 ADDP)",
    "DELP": "the symbol is not the current one (Tabela 1 DELP)",
    "NEWPW": "bad format of the password (Tabela 1 NEWPW)",
}


class Unreachable(BusError):
    """A module of the file answers neither at its address nor at its ``was``."""


class NotAModule(BusError):
    """Something answers ``HELLO`` with a text that is no HCTMPS1 variant."""


class Refusal(BusError):
    """A write the module refused, did not answer, or whose read-back differs."""

    def __init__(self, setting: str, why: str) -> None:
        super().__init__(f"{setting}: {why}")
        self.setting = setting
        self.why = why


async def identify(master: BusMaster, address: str) -> str:
    """The variant of the module at ``address`` (``HELLO``)."""
    hello = await master.hello(address)
    variant = variant_of(hello)
    if variant is None:
        raise NotAModule(f"{address} answers HELLO with {hello!r}: not an HCTMPS1 module")
    return variant


async def _connect(master: BusMaster, address: str, password: str) -> bool:
    """``CONNECT`` sent once: each wrong password the module hears counts towards its
    lockout (5 in 60 s, hctmps1.md section 4), so a silence is not answered by sending the
    password again but by asking ``LISTP``, which only an open ``<connect>`` answers (the
    reply may have been lost). A ``DISCONNECT`` first closes a context left open, so that
    ``LISTP`` answers only if this password opened one."""
    with contextlib.suppress(BusError):
        await master.disconnect(address)
    try:
        return await master.command(address, "CONNECT", password, retries=0) == "<OK>"
    except NoReply:
        pass
    try:
        await master.listp(address)
    except NoReply:
        return False
    return True


async def open_context(
    master: BusMaster, address: str, password: str, wanted: str | None = None
) -> bool:
    """``CONNECT`` to ``address``: with ``wanted`` (the file's password) first if given, then
    with ``password``; True if only ``password`` opened it (the password is to change).

    Each is sent once (:func:`_connect`)."""
    if wanted is not None:
        if await _connect(master, address, wanted):
            return False
        if wanted == password:
            raise ConnectRefused(f"{address}: CONNECT got no reply: wrong password or locked out")
    if await _connect(master, address, password):
        return wanted is not None
    raise ConnectRefused(
        f"{address}: CONNECT got no reply: wrong password (give it with --password) or locked"
        " out (5 wrong passwords in 60 s lock CONNECT for 60 s)"
    )


async def _read_settings(master: BusMaster, address: str) -> tuple[tuple[str, ...], str | None]:
    return tuple(await master.listsup(address)), await master.listp(address)


async def read_module(
    master: BusMaster, address: str, password: str = FACTORY_PASSWORD
) -> ModuleState:
    """What the module at ``address`` holds (``HELLO``; ``LISTSUP``, ``LISTP`` inside
    ``<connect>``; ``GETMODE``)."""
    variant = await identify(master, address)
    await open_context(master, address, password)
    try:
        supervisors, symbol = await _read_settings(master, address)
    finally:
        with contextlib.suppress(BusError):
            await master.disconnect(address)
    return ModuleState(address, variant, supervisors, symbol, await master.getmode(address))


async def pull(
    master: BusMaster, addresses: Sequence[str] | None, password: str = FACTORY_PASSWORD
) -> list[ModuleState]:
    """Every module's settings: those at ``addresses``, or every module a scan finds."""
    targets = list(dict.fromkeys(addresses)) if addresses else list(await master.scan())
    if not targets:
        raise Unreachable("no module answered HELLO")
    states = []
    for address in targets:
        try:
            states.append(await read_module(master, address, password))
        except NoReply:
            _refuse_foreign(master)
            raise Unreachable(
                f"{address}: no reply (is it on this bus? bus scan lists them)"
            ) from None
    return states


def _refuse_foreign(master: BusMaster) -> None:
    """Raise :class:`ForeignPeer` if nothing but text lines came back (an ALA1 logger's
    ``ERROR``): the URL is no bus, rather than "no module answers"."""
    if master.frames_from_others == 0 and master.garbage:
        master._refuse_foreign()


# -- plan ----------------------------------------------------------------------------------


@dataclass
class ModulePlan:
    """One module of the file: where it answers, what it holds, what would change."""

    entry: ModuleEntry
    at: str | None = None
    have: ModuleState | None = None
    changes: list[Change] = field(default_factory=list)
    #: Why the module cannot be planned: unreachable, CONNECT refused (apply: that module fails).
    failure: str | None = None
    #: A value the bus refutes (another variant): apply writes nothing at all.
    refused: str | None = None
    #: Only ``--password`` opened ``<connect>``: the file's password is to be set.
    password_differs: bool = False

    @property
    def label(self) -> str:
        address = self.entry.want.address
        return address if self.at in (None, address) else f"{address} (now {self.at})"


async def locate(master: BusMaster, entry: ModuleEntry) -> tuple[str, str]:
    """Where the module of ``entry`` answers now, and its variant: at its address, else at
    its ``was``."""
    for address in (entry.want.address, entry.was):
        if address is None:
            continue
        with contextlib.suppress(NoReply):
            return address, await identify(master, address)
    _refuse_foreign(master)
    if entry.was is not None:
        raise Unreachable(f"no module answers at {entry.want.address} nor at {entry.was} (was)")
    raise Unreachable(
        f"no module answers at {entry.want.address} (if the module is to get this address,"
        ' say where it answers now: was = "ID", such as its factory ID)'
    )


async def plan_module(master: BusMaster, entry: ModuleEntry, password: str) -> ModulePlan:
    result = ModulePlan(entry)
    try:
        result.at, variant = await locate(master, entry)
        if entry.want.variant not in (None, variant):
            error = entry.fail(
                "variant", f"{result.at} is a {variant} server, not {entry.want.variant}"
            )
            result.refused = str(error)
            return result
        differs = await open_context(master, result.at, password, entry.password)
        result.password_differs = differs
        try:
            supervisors, symbol = await _read_settings(master, result.at)
        finally:
            with contextlib.suppress(BusError):
                await master.disconnect(result.at)
        autonomous = await master.getmode(result.at)
        result.have = ModuleState(result.at, variant, supervisors, symbol, autonomous)
        result.changes = differences(entry, result.have, password_differs=differs)
    except ForeignPeer:
        raise  # not a bus at all: no module of the file can be planned
    except BusError as exc:
        result.failure = f"{entry.fail('address', str(exc))}"
    return result


async def plan(master: BusMaster, settings: SettingsFile, password: str) -> list[ModulePlan]:
    """What applying ``settings`` would change on each of its modules (nothing is written)."""
    return [await plan_module(master, entry, password) for entry in settings.modules]


# -- apply ---------------------------------------------------------------------------------


@dataclass
class ModuleReport:
    """What :func:`apply_module` did to one module."""

    label: str
    applied: list[Change] = field(default_factory=list)
    not_applied: list[Change] = field(default_factory=list)
    failure: str | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def status(self) -> str:
        if self.failure is not None:
            return "failed"
        return "changed" if self.applied else "unchanged"


class _Writer:
    """The writes of one module inside ``<connect>``, each checked."""

    def __init__(self, master: BusMaster, address: str) -> None:
        self.master = master
        self.address = address

    async def send(
        self,
        setting: str,
        command: str,
        param: str | None = None,
        took: Callable[[], Awaitable[bool]] | None = None,
    ) -> None:
        """Send a write; a ``<FA>`` or no reply is a refusal unless ``took`` (a read-back)
        shows it took effect all the same: the master resends a request whose reply was
        lost, and a second ``DELSUP`` answers ``<FA>``, a second ``SETMID`` nothing (the
        module already answers at its new ID)."""
        what = command if param is None else f"{command} {param}"
        try:
            reply: str | None = await self.master.command(self.address, command, param)
        except NoReply:
            reply = None
        if reply == "<OK>":
            return
        if took is not None:
            with contextlib.suppress(NoReply):
                if await took():
                    return
        if reply is None:
            raise Refusal(setting, f"no reply from {self.address} to {what}")
        why = REFUSALS.get(command, "Tabela 1 gives it no other answer than <OK>")
        raise Refusal(setting, f"{what} answered {reply}: {why}")

    async def check(
        self, setting: str, read: Callable[[], Awaitable[object]], want: object, shown: str
    ) -> None:
        try:
            got = await read()
        except NoReply:
            raise Refusal(setting, f"no reply reading it back from {self.address}") from None
        if got != want:
            raise Refusal(setting, f"read back {got!r}, not {shown}")


async def _write_eeprom(w: _Writer, entry: ModuleEntry, have: ModuleState, names: set[str]) -> None:
    """The EEPROM settings of ``names`` in the order the module accepts (the address last)."""
    m, want = w.master, entry.want

    async def symbol_is_wanted() -> bool:
        return await m.listp(w.address) == want.symbol

    def listed(sup: str, wanted: bool) -> Callable[[], Awaitable[bool]]:
        async def check() -> bool:
            return (sup in await m.listsup(w.address)) == wanted

        return check

    if "symbol" in names:
        if want.symbol is None:
            await w.send("symbol", "DELP", have.symbol or "", symbol_is_wanted)
        else:
            await w.send("symbol", "ADDP", want.symbol, symbol_is_wanted)
        await w.check("symbol", lambda: m.listp(w.address), want.symbol, want.symbol or "(none)")
    if "supervisors" in names:
        for sup in have.supervisors:
            if sup not in want.supervisors:
                await w.send("supervisors", "DELSUP", sup, listed(sup, False))
        for sup in want.supervisors:
            if sup not in have.supervisors:
                await w.send("supervisors", "ADDSUP", sup, listed(sup, True))

        async def supervisors() -> set[str]:
            return set(await m.listsup(w.address))

        shown = show_ids(want.supervisors)
        await w.check("supervisors", supervisors, set(want.supervisors), shown)
    if "password" in names and entry.password is not None:
        await w.send("password", "NEWPW", entry.password)
    if "address" in names:
        hello = HELLO_TEXTS.get(have.variant or "")

        async def renamed() -> bool:
            return await m.hello(want.address) == hello

        await w.send("address", "SETMID", want.address, renamed)
        w.address = want.address  # the module answers at its new ID from now on (§2)
        await w.check("address", lambda: m.hello(w.address), hello, f"{want.address} answering")


async def _save_and_verify(w: _Writer, want: ModuleState) -> None:
    """``SAVEEE``, then ``REINIT`` (reload from the EEPROM) and read everything back (§4)."""
    await w.send("save", "SAVEEE")
    await w.send("save", "REINIT")
    supervisors, symbol = await _read_settings(w.master, w.address)
    if set(supervisors) != set(want.supervisors) or symbol != want.symbol:
        raise Refusal(
            "save",
            f"after SAVEEE and REINIT the module holds supervisors {show_ids(supervisors)},"
            f" symbol {symbol or '(none)'}",
        )


async def apply_module(master: BusMaster, mp: ModulePlan, password: str) -> ModuleReport:
    """Apply the file's settings to the module of ``mp`` (located by :func:`plan`)."""
    entry = mp.entry
    report = ModuleReport(mp.label)
    if mp.failure is not None or mp.at is None or mp.have is None:
        report.failure = mp.failure or "not located"
        report.notes.append("nothing written")
        return report
    writer = _Writer(master, mp.at)
    try:
        # The password that opened it for the plan, so that no wrong one is tried again
        # (each counts towards the lockout, hctmps1.md section 4).
        differs = mp.password_differs
        known = password if differs or entry.password is None else entry.password
        if not await _connect(master, mp.at, known):
            raise ConnectRefused(f"{mp.at}: CONNECT got no reply (it did for the plan)")
        # Read again inside the context: the file, not an older plan, decides what is written.
        supervisors, symbol = await _read_settings(master, mp.at)
    except BusError as exc:
        report.failure = str(exc)
        report.not_applied = list(mp.changes)
        report.notes.append("nothing written")
        return report
    have = ModuleState(mp.at, mp.have.variant, supervisors, symbol, mp.have.autonomous)
    changes = differences(entry, have, password_differs=differs)
    eeprom = [c for c in changes if c.setting != "autonomous"]
    try:
        if eeprom:
            await _write_eeprom(writer, entry, have, {c.setting for c in eeprom})
            await _save_and_verify(writer, entry.want)
            report.notes.append("saved (SAVEEE), read back after REINIT")
    except Refusal as exc:
        report.failure = f"{exc.setting}: {exc.why}"
        report.not_applied = list(changes)
        writer.address = await _roll_back(
            master, (writer.address, entry.want.address), mp.at, report
        )
        return report
    finally:
        with contextlib.suppress(BusError):
            await master.disconnect(writer.address)
    report.applied = list(eeprom)
    if differs and entry.password is not None:
        if await _connect(master, writer.address, entry.password):
            await master.disconnect(writer.address)
            report.notes.append("the new password opens <connect>")
        else:
            report.failure = "password: the new password does not open <connect>"
    for change in changes:
        if change.setting == "autonomous" and report.failure is None:
            try:
                await _write_autonomous(master, writer.address, entry.want.autonomous)
                report.applied.append(change)
            except Refusal as exc:
                report.failure = f"{exc.setting}: {exc.why}"
                report.not_applied.append(change)
    return report


async def _write_autonomous(master: BusMaster, address: str, on: bool) -> None:
    """``AUTOON``/``AUTOOFF``, then ``GETMODE`` (Tabela 1; no ``<connect>`` needed)."""
    try:
        await (master.autoon(address) if on else master.autooff(address))
        now = await master.getmode(address)
    except NoReply:
        raise Refusal("autonomous", f"no reply from {address}") from None
    if now != on:
        raise Refusal("autonomous", f"GETMODE says {'MDISON' if now else 'MDISOF'}")


async def _roll_back(
    master: BusMaster, addresses: tuple[str, str], old: str, report: ModuleReport
) -> str:
    """``REINIT`` at whichever ID the module answers: its saved settings come back, with
    the ID it had (``old``), which is returned."""
    for target in dict.fromkeys((*addresses, old)):
        with contextlib.suppress(BusError):
            if await master.command(target, "REINIT", retries=1) == "<OK>":
                report.notes.append("nothing saved: REINIT restored the saved settings")
                return old
    report.notes.append("nothing saved (REINIT got no reply: the module's RAM may differ)")
    return addresses[0]


async def apply(
    master: BusMaster, plans: Sequence[ModulePlan], password: str
) -> list[ModuleReport]:
    """Apply each planned module in turn; a failure on one never stops the others."""
    return [await apply_module(master, mp, password) for mp in plans]
