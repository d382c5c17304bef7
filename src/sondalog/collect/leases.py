"""Which sources this collector polls when several share them (issue 24): the pure part.

Several ``sondalog collect`` processes with the same source list and a ``[cluster]`` table
split the sources through two tables on the ``[postgres]`` server
(:mod:`sondalog.collect.lease_pg`, docs/scaling.md "Collectors that share the work"):

- ``collector_members``: one row per running collector, ``expires`` renewed at every turn;
- ``collector_leases``: one row per source, its ``holder`` and when the lease ``expires``
  (the database's clock), and what the next holder resumes from (the cursor).

At every turn (every ``lease / 3`` seconds) a collector reads both tables and
:func:`plan` says what to do: keep up to its :func:`quota` of the sources it holds (renewed),
release the rest, and take free ones (no holder, or an expired lease) up to the quota, the
ones it prefers first (a hash of member and source: each member prefers other sources, so
they seldom reach for the same one, and a source goes back to the same member when the
membership comes back). Taking is a conditional ``UPDATE`` (``FOR UPDATE SKIP LOCKED``), so
a source never has two holders in the table.

A collector believes it holds a source until ``sent + lease`` (:class:`Holding`), ``sent``
being when it sent the statement that took or renewed it, before the database set
``expires = its now + lease``: its belief ends no later than the lease, so it has stopped
polling a source before anyone else may take it (clocks that run at the same rate; their
offsets do not matter, every lease time is the database's).
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class Lease:
    """A source's row: who holds it until when (seconds, the database's clock)."""

    holder: str | None
    expires: float


@dataclass(frozen=True, slots=True)
class Plan:
    """What one turn does."""

    quota: int
    #: Held and renewed now.
    keep: tuple[str, ...]
    #: Held and given back (stop polling them first).
    release: tuple[str, ...]
    #: Free sources, the preferred first; take at most :attr:`want` of them.
    take: tuple[str, ...]
    want: int


def quota(sources: int, members: int) -> int:
    """Each member's share: ``ceil(sources / members)`` (every source has room)."""
    return math.ceil(sources / max(1, members))


@functools.lru_cache(maxsize=1 << 16)
def preference(member: str, source: str) -> int:
    """How much ``member`` wants ``source`` (rendezvous hashing: stable, spread)."""
    digest = hashlib.blake2b(f"{member}\0{source}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "big")


def live(me: str, members: Mapping[str, float], now: float) -> set[str]:
    """The members whose row has not expired at ``now``, and ``me``."""
    return {name for name, expires in members.items() if expires > now} | {me}


def is_free(lease: Lease | None, now: float) -> bool:
    return lease is None or lease.holder is None or lease.expires <= now


def plan(
    me: str,
    sources: Sequence[str],
    leases: Mapping[str, Lease],
    members: Mapping[str, float],
    now: float,
) -> Plan:
    """The turn of member ``me`` with ``sources`` (its file's), the tables as read at
    ``now`` (the database's clock)."""
    share = quota(len(sources), len(live(me, members, now)))

    def wanted(source: str) -> int:
        return -preference(me, source)

    mine = sorted(
        (s for s in sources if (lease := leases.get(s)) is not None and lease.holder == me),
        key=wanted,
    )
    mine = [s for s in mine if not is_free(leases[s], now)]
    keep, release = mine[:share], mine[share:]
    free = sorted((s for s in sources if is_free(leases.get(s), now)), key=wanted)
    return Plan(share, tuple(keep), tuple(release), tuple(free), max(0, share - len(keep)))


@dataclass
class Holding:
    """The sources this member believes it holds, each until a time of its own clock."""

    lease: float
    until: dict[str, float] = field(default_factory=dict)

    def renewed(self, sources: Iterable[str], sent: float) -> None:
        """``sources`` were taken or renewed by a statement sent at ``sent``."""
        for source in sources:
            self.until[source] = sent + self.lease

    def drop(self, sources: Iterable[str]) -> None:
        for source in sources:
            self.until.pop(source, None)

    def holds(self, source: str, now: float) -> bool:
        return self.until.get(source, -math.inf) > now

    def held(self, now: float) -> set[str]:
        return {s for s, until in self.until.items() if until > now}

    def lapsed(self, now: float) -> list[str]:
        """Sources whose belief ran out (no renewal in time): stop polling them."""
        gone = [s for s, until in self.until.items() if until <= now]
        self.drop(gone)
        return gone


def default_lease(intervals: Iterable[float]) -> float:
    """Half the shortest contact interval, within 1..30 s: a killed member's sources are
    polled again within ``interval + lease + lease / 3 + spread`` < 2 intervals."""
    shortest = min(intervals, default=60.0)
    return min(30.0, max(1.0, shortest / 2))
