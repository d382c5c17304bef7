"""Module state and the per-line transaction (spec notes §3: whole-line atomicity).

:class:`ModuleState` holds what the module remembers: parameters written (non-volatile, in an
:class:`NvStore`), the clock offset (a battery-backed clock), and the four line counters of
§8.5.7 (RAM, zero at power-up). A command line runs against a :class:`Transaction`: reads see
the line's own earlier writes; nothing reaches the store unless the whole line succeeds, and
then it is committed in one store transaction before the answer is released.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Protocol

from sondalog.ala1.model import Identity
from sondalog.ala1.params import RESET_KEEPS, KeyInfo, storage_keys

_EPOCH = datetime(1970, 1, 1)
#: The clock of a new virtual module (§11 factory value of ``date``).
FACTORY_DATE = datetime(2000, 1, 1)


def to_seconds(moment: datetime) -> float:
    return (moment - _EPOCH).total_seconds()


def from_seconds(seconds: float) -> datetime:
    return _EPOCH + timedelta(seconds=int(seconds // 1))


class NvStore(Protocol):
    """Non-volatile memory of one module (DESIGN.md point 5)."""

    def load(self) -> tuple[dict[str, str], float | None]:
        """Parameters written so far, and the clock offset (None for a new module)."""
        ...

    def commit(
        self, changes: dict[str, str | None], clock_offset: float | None, clear_record: bool
    ) -> None:
        """Durably apply ``changes`` (None = back to the factory value) in one transaction."""
        ...


class ModuleState:
    """What one ALA1 module remembers."""

    def __init__(self, identity: Identity, store: NvStore, host_now: float) -> None:
        self.identity = identity
        self.store = store
        self.keys: dict[str, KeyInfo] = storage_keys(identity.version)
        values, offset = store.load()
        self.values = {k: v for k, v in values.items() if k in self.keys}
        if offset is None:
            offset = to_seconds(FACTORY_DATE) - host_now
            store.commit({}, offset, clear_record=False)
        self.clock_offset = offset
        self.counters = [0, 0, 0, 0]

    def module_time(self, host_now: float) -> datetime:
        return from_seconds(host_now + self.clock_offset)

    def get(self, key: str) -> str:
        """A committed value (outside any line)."""
        return Transaction(self, 0.0).get(key)

    def begin(self, host_now: float) -> Transaction:
        return Transaction(self, host_now)


class Transaction:
    """One command line's view of the module (implements :class:`~.model.View`)."""

    def __init__(self, state: ModuleState, host_now: float) -> None:
        self.state = state
        self.identity = state.identity
        self.host_now = host_now
        self.changes: dict[str, str | None] = {}
        self.reset_all = False
        self.clock: datetime | None = None
        self.record_cleared = False

    def default(self, key: str) -> str:
        info = self.state.keys[key]
        return info.leaf.default_for(self, info.indices)

    def get(self, key: str) -> str:
        if key in self.changes:
            value = self.changes[key]
        elif self.reset_all and key not in RESET_KEEPS:
            value = None
        else:
            value = self.state.values.get(key)
        return self.default(key) if value is None else value

    def set(self, key: str, value: str) -> None:
        if key not in self.state.keys:
            raise KeyError(key)
        self.changes[key] = value

    def reset(self, keep: tuple[str, ...]) -> None:
        self.reset_all = True
        for key in list(self.changes):
            if key not in keep:
                self.changes[key] = None

    def now(self) -> datetime:
        if self.clock is not None:
            return self.clock
        return self.state.module_time(self.host_now)

    def set_clock(self, moment: datetime) -> None:
        self.clock = moment

    def clear_record(self) -> None:
        self.record_cleared = True

    def commit(self) -> None:
        """Make the line's effects durable, then visible."""
        state = self.state
        changes = dict(self.changes)
        if self.reset_all:
            for key in state.values:
                if key not in RESET_KEEPS and key not in changes:
                    changes[key] = None
        offset = None
        if self.clock is not None:
            offset = to_seconds(self.clock) - self.host_now
        if not changes and offset is None and not self.record_cleared:
            return
        state.store.commit(changes, offset, self.record_cleared)
        for key, value in changes.items():
            if value is None:
                state.values.pop(key, None)
            else:
                state.values[key] = value
        if offset is not None:
            state.clock_offset = offset
