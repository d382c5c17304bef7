"""What a module's state shares with the modules of the same version (issue 24: a fleet
of 10,000 loggers): factory values that depend on nothing else, parsed table files, and the
identity as a :class:`~sondalog.ala1.shared.Derived` may read it (:class:`NotedIdentity`)."""

from __future__ import annotations

import functools

from sondalog.ala1.model import Identity, Limits, Version
from sondalog.ala1.params import storage_keys
from sondalog.protocol.tables import TableSet


@functools.cache
def fixed_defaults(version: Version) -> dict[str, str]:
    """Factory values that depend on nothing else: shared by every module (issue 24)."""
    keys = storage_keys(version).items()
    return {key: i.leaf.default for key, i in keys if isinstance(i.leaf.default, str)}


@functools.lru_cache(maxsize=64)
def shared_tables(listing: bytes, data: bytes) -> TableSet:
    """The tables of these file areas, shared by the modules holding the same (issue 24)."""
    return TableSet(listing, data)


class NotedIdentity:
    """A module's identity that notes whether anything but its version, device and limits
    (what a :class:`~sondalog.ala1.shared.Derived` is shared by) was read: the serial
    number (``i description``'s factory value, §6.3.6), the program."""

    __slots__ = ("identity", "personal")

    def __init__(self, identity: Identity) -> None:
        self.identity = identity
        self.personal = False

    @property
    def version(self) -> Version:
        return self.identity.version

    @property
    def device(self) -> str:
        return self.identity.device

    @property
    def limits(self) -> Limits:
        return self.identity.limits

    def __getattr__(self, name: str) -> object:
        self.personal = True
        return getattr(self.identity, name)
