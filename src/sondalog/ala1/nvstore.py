"""A module's non-volatile memory as the module sees it (DESIGN.md point 5; spec notes §3).

The stores themselves are backends (:mod:`sondalog.backends.store.ala1_nv`).
"""

from __future__ import annotations

from typing import Protocol

from sondalog.ala1.record import RecordChanges, Sealed


class NvStore(Protocol):
    """Non-volatile memory of one module (DESIGN.md point 5)."""

    def load(self) -> tuple[dict[str, str], float | None]:
        """Parameters written so far, and the clock offset (None for a new module)."""
        ...

    def load_record(self) -> tuple[list[str] | Sealed, int, bool, bool]:
        """Record rows oldest first (or as a record in RAM held them: a restore), first
        sequence number, wrapped and refused flags."""
        ...

    def load_files(self) -> dict[str, bytes]:
        """The file areas (``list``, ``data``) of §6.15."""
        ...

    def write_file(self, area: str, data: bytes) -> None:
        """Durably replace a file area."""
        ...

    def last_seen(self) -> float | None:
        """The host time of the latest commit, if any."""
        ...

    def commit(
        self,
        changes: dict[str, str | None],
        clock_offset: float | None,
        record: RecordChanges | None = None,
        seen: float | None = None,
    ) -> None:
        """Durably apply ``changes`` (None = back to the factory value) in one transaction;
        ``seen`` is the host time of the change."""
        ...

    def commit_scheduled(self, record: RecordChanges, seen: float) -> None:
        """Rows the module sampled on its own (no command line waits for them): durable by
        the end of the current turn, so a store may group the commits of many modules in
        one transaction (group commit, issue 11); a store without it commits at once."""
        ...
