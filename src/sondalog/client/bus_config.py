"""HCTMPS1 modules' settings as a file: the model, reading it, writing it, the diff (issue 22).

A settings file holds one ``[[module]]`` per module: what the command table (Tabela 1 of the
manual; docs/hctmps1.md §4) lets a host set and read back::

    [[module]]
    address = "T7"            # SETMID, the module's ID on the bus
    variant = "temp"          # HELLO: checked, never written
    supervisors = ["LOG1"]    # ADDSUP / DELSUP / LISTSUP
    symbol = "TEMP1"          # ADDP / DELP / LISTP
    autonomous = true         # AUTOON / AUTOOFF / GETMODE (RAM: lost at power-up)

and, written only by hand, ``was`` (where the module answers before the file is applied,
such as its factory ID) and ``password`` (the password it shall have: ``NEWPW``; it cannot
be read back, so ``pull`` never writes it). A setting left out means its factory value
(hctmps1.md §1: no supervisors, no symbol, autonomous mode off), so that a file describes
the whole configuration; ``password`` left out is left as it is. The file is read through
:mod:`sondalog.config` (``FILE:LINE: module[0].symbol: ...``) and every value is checked by
the module's own rules (:mod:`sondalog.protocol.hctmps1_settings`) before anything is
written.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.config import Table, load
from sondalog.protocol.hctmps1_frames import is_valid_id
from sondalog.protocol.hctmps1_settings import (
    HELLO_TEXTS,
    MAX_SUPERVISORS,
    is_valid_password,
    is_valid_symbol,
)

MODULE_KEYS = frozenset(
    {"address", "variant", "supervisors", "symbol", "autonomous", "was", "password"}
)
#: Settings the issue names that the command table has no command for (docs/decisions.md).
NOT_SETTABLE = {
    "calibration": "the HCTMPS1 command table (Tabela 1) has no command that sets or reads a"
    " calibration; the module cannot be calibrated over the bus",
    "temporary": "the temporary distribution list (CSSERVON) is RAM that each watching host"
    " sets for itself (sondalog bus watch), not a setting",
}
_ID_TEXT = "a module ID: 1 to 8 of A-Z a-z 0-9 _ -"


@dataclass(frozen=True, slots=True)
class ModuleState:
    """The settings one module holds (read from it, or wanted by a file)."""

    address: str
    variant: str | None = None
    supervisors: tuple[str, ...] = ()
    symbol: str | None = None
    autonomous: bool = False


@dataclass(frozen=True, slots=True)
class ModuleEntry:
    """One ``[[module]]`` of a settings file: the wanted state and how to reach the module."""

    want: ModuleState
    was: str | None = None
    password: str | None = None
    table: Table | None = field(default=None, compare=False, repr=False)

    def fail(self, key: str | None, message: str) -> Exception:
        """A :class:`~sondalog.config.ConfigError` at ``key`` of this entry."""
        if self.table is None:
            return ValueError(f"{self.want.address}: {key}: {message}")
        return self.table.fail(key, message)


@dataclass(frozen=True, slots=True)
class SettingsFile:
    path: Path | None
    modules: tuple[ModuleEntry, ...]


def load_settings(path: Path) -> SettingsFile:
    """Read and check a settings file; raises :class:`~sondalog.config.ConfigError`."""
    return read_settings(load(path))


def read_settings(root: Table) -> SettingsFile:
    root.keys({"module"})
    entries = [_entry(table) for table in root.tables("module", required=True)]
    seen: dict[str, int] = {}
    for n, entry in enumerate(entries):
        address = entry.want.address
        if address in seen:
            raise entry.fail("address", f"{address} is also the address of module[{seen[address]}]")
        seen[address] = n
    for entry in entries:
        if entry.was is not None and entry.was in seen:
            raise entry.fail(
                "was", f"{entry.was} is the address of module[{seen[entry.was]}] of this file"
            )
    wases = [e.was for e in entries if e.was is not None]
    for entry in entries:
        if entry.was is not None and wases.count(entry.was) > 1:
            raise entry.fail("was", f"{entry.was} is the was of another module of this file")
    return SettingsFile(root.file, tuple(entries))


def _entry(table: Table) -> ModuleEntry:
    for key, why in NOT_SETTABLE.items():
        if key in table:
            raise table.fail(key, why)
    table.keys(MODULE_KEYS)
    address = table.text("address", pattern=r"[A-Za-z0-9_-]{1,8}", what=_ID_TEXT)
    variant = table.opt_text("variant", choices=sorted(HELLO_TEXTS))
    supervisors = table.texts("supervisors", ())
    for value in supervisors:
        if not is_valid_id(value):
            raise table.fail("supervisors", f"{value!r} is not {_ID_TEXT} (ADDSUP would refuse it)")
    if len(set(supervisors)) != len(supervisors):
        twice = next(s for s in supervisors if supervisors.count(s) > 1)
        raise table.fail("supervisors", f"{twice} is listed twice")
    if len(supervisors) > MAX_SUPERVISORS:
        raise table.fail(
            "supervisors", f"{len(supervisors)} supervisors: the module holds at most 8 (ADDSUP)"
        )
    symbol = table.text("symbol", "", empty=True) or None
    if symbol is not None and not is_valid_symbol(symbol):
        raise table.fail(
            "symbol", f'{symbol!r}: 1 to 8 of A-Z a-z 0-9 _, or "" for none (ADDP would refuse it)'
        )
    was = table.opt_text("was", pattern=r"[A-Za-z0-9_-]{1,8}", what=_ID_TEXT)
    if was == address:
        raise table.fail("was", f"is the address itself ({address}); leave it out")
    password = table.opt_text("password")
    if password is not None and not is_valid_password(password):
        raise table.fail(
            "password", "1 to 16 printable characters without |, comma or space (NEWPW)"
        )
    want = ModuleState(
        address, variant, tuple(supervisors), symbol, table.flag("autonomous", False)
    )
    return ModuleEntry(want, was, password, table)


# -- the difference ------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Change:
    """One setting to change: its name, the values before and after, as the plan shows them."""

    setting: str
    old: str
    new: str

    def __str__(self) -> str:
        return f"{self.setting}: {self.old} -> {self.new}"


def show_ids(ids: Sequence[str]) -> str:
    return ", ".join(ids) if ids else "(none)"


def differences(
    entry: ModuleEntry, have: ModuleState, *, password_differs: bool = False
) -> list[Change]:
    """What applying ``entry`` to a module holding ``have`` changes, in the order it is
    applied (the address last). The supervisors' order is not a difference."""
    want = entry.want
    changes = []
    if want.symbol != have.symbol:
        changes.append(Change("symbol", have.symbol or "(none)", want.symbol or "(none)"))
    if set(want.supervisors) != set(have.supervisors):
        changes.append(
            Change("supervisors", show_ids(have.supervisors), show_ids(want.supervisors))
        )
    if password_differs:
        changes.append(Change("password", "(another)", "(the file's)"))
    if want.address != have.address:
        changes.append(Change("address", have.address, want.address))
    if want.autonomous != have.autonomous:
        changes.append(Change("autonomous", _on(have.autonomous), _on(want.autonomous)))
    return changes


def _on(flag: bool) -> str:
    return "on" if flag else "off"


# -- writing a file ------------------------------------------------------------------------

_HEADER = """\
# HCTMPS1 modules' settings, written by sondalog bus config pull.
# Apply with: sondalog bus config plan|apply BUS-URL FILE (docs/config-bus.md).
# Commands are those of the HCTMPS1 command table (Tabela 1; docs/hctmps1.md section 4).
# A setting left out is at its factory value (no supervisors, no symbol, autonomous off).
"""


def render(states: Sequence[ModuleState], *, full: bool = False) -> str:
    """``states`` as a settings file; factory values are left out unless ``full``."""
    parts = [_HEADER]
    for state in states:
        lines = ["", "[[module]]", _line("address", state.address, "SETMID: the module's ID")]
        if state.variant is not None:
            lines.append(_line("variant", state.variant, f"HELLO: {HELLO_TEXTS[state.variant]}"))
        if full or state.supervisors:
            lines.append(
                _line(
                    "supervisors",
                    list(state.supervisors),
                    "ADDSUP/DELSUP/LISTSUP: where its data goes, at most 8",
                )
            )
        if full or state.symbol is not None:
            lines.append(
                _line("symbol", state.symbol or "", "ADDP/DELP/LISTP: the variable's symbol")
            )
        if full or state.autonomous:
            lines.append(
                _line(
                    "autonomous",
                    state.autonomous,
                    "AUTOON/AUTOOFF/GETMODE: sends on its own (RAM: off after power-up)",
                )
            )
        parts.append("\n".join(lines) + "\n")
    return "".join(parts)


def _line(key: str, value: str | bool | list[str], comment: str) -> str:
    if isinstance(value, str):
        text = json.dumps(value)
    elif isinstance(value, list):
        text = "[" + ", ".join(json.dumps(v) for v in value) + "]"
    else:
        text = "true" if value else "false"
    return f"{f'{key} = {text}':<30} # {comment}"
