"""The pure lease logic of collectors that share their sources (issue 24,
``sondalog.collect.leases``), on a stepped clock.

A model of the two lease tables applies each member's :func:`plan` as
``sondalog.collect.lease_pg`` does (member row, release, renew of held rows whose lease has
not run out, conditional take of free rows in the member's order), with the database's
statements sent a little before they run. Hypothesis draws the sources,
the members, their phases and kills, stalls (a member that misses its turns) and joins, and
checks at every step:

- safety: no source is believed held by two living members at once (a stalled member
  still believes until its lease runs out locally), and the table never has two holders;
- liveness: from ``lease + 2 turns`` after the last disturbance on, every source has
  exactly one holder, a living member that believes it holds it, and no member holds more
  than its quota (balanced).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect.leases import (
    Holding,
    Lease,
    default_lease,
    is_free,
    plan,
    preference,
    quota,
)

LEASE = 3.0
PERIOD = LEASE / 3
STEP = PERIOD / 5
#: How much later than the member's clock the database runs a statement (latency).
LATENCY = PERIOD / 4


class Tables:
    """The lease tables as ``lease_pg`` changes them (each statement atomic)."""

    def __init__(self, sources: list[str]) -> None:
        self.leases = {s: Lease(None, 0.0) for s in sources}
        self.members: dict[str, float] = {}

    def renew(self, me: str, sources: tuple[str, ...], now: float) -> set[str]:
        kept = set()
        for s in sources:
            lease = self.leases[s]
            if lease.holder == me and lease.expires > now:
                self.leases[s] = Lease(me, now + LEASE)
                kept.add(s)
        return kept

    def take(self, me: str, candidates: tuple[str, ...], want: int, now: float) -> list[str]:
        taken = [s for s in candidates if is_free(self.leases[s], now)][: max(0, want)]
        for s in taken:
            self.leases[s] = Lease(me, now + LEASE)
        return taken

    def release(self, me: str, sources: tuple[str, ...]) -> None:
        for s in sources:
            if self.leases[s].holder == me:
                self.leases[s] = Lease(None, 0.0)


@dataclass
class Member:
    name: str
    next_turn: float
    holding: Holding = field(default_factory=lambda: Holding(LEASE))
    alive: bool = True
    stalled_until: float = -math.inf

    def turn(self, tables: Tables, sources: list[str], now: float, lag: float) -> None:
        """The turn's statements run at ``now`` (the answers come back then), sent ``lag``
        earlier: the member counts its leases from then."""
        db_now, sent = now, now - lag
        tables.members[self.name] = db_now + LEASE
        todo = plan(self.name, sources, tables.leases, tables.members, db_now)
        self.holding.drop(todo.release)
        tables.release(self.name, todo.release)
        kept = tables.renew(self.name, todo.keep, db_now)
        self.holding.renewed(kept, sent)
        self.holding.drop(set(todo.keep) - kept)
        self.holding.renewed(tables.take(self.name, todo.take, todo.want, db_now), sent)
        self.holding.lapsed(now)


@dataclass(frozen=True)
class Disturbance:
    at: float
    kind: str  # "kill", "join", "stall"
    who: int
    length: float


disturbances = st.builds(
    Disturbance,
    at=st.floats(0.0, 20.0),
    kind=st.sampled_from(["kill", "join", "stall"]),
    who=st.integers(0, 7),
    length=st.floats(0.5, 3 * LEASE),
)


def _run(n_sources: int, phases: list[float], events: list[Disturbance], lags: list[float]):
    sources = [f"s{i:02}" for i in range(n_sources)]
    tables = Tables(sources)
    members = [Member(f"m{i}", phase) for i, phase in enumerate(phases)]
    events = sorted(events, key=lambda e: e.at)
    settled_from = PERIOD  # the first turns
    now = 0.0
    end = max([e.at + e.length for e in events], default=0.0) + LEASE + 6 * PERIOD
    ticks = 0
    while now <= end:
        for e in [e for e in events if now - STEP < e.at <= now]:
            living = [m for m in members if m.alive]
            if e.kind == "join":
                members.append(Member(f"m{len(members)}", now))
                settled_from = max(settled_from, now)
            elif e.kind == "kill" and len(living) > 1:
                living[e.who % len(living)].alive = False
                settled_from = max(settled_from, now)
            elif e.kind == "stall" and living:
                victim = living[e.who % len(living)]
                victim.stalled_until = max(victim.stalled_until, now + e.length)
                settled_from = max(settled_from, victim.stalled_until)
        for m in members:
            if m.alive and m.next_turn <= now:
                m.next_turn = now + PERIOD
                if now >= m.stalled_until:
                    m.turn(tables, sources, now, lags[ticks % len(lags)])
                    ticks += 1
        _check(tables, members, sources, now, settled_from)
        now += STEP


def _check(
    tables: Tables, members: list[Member], sources: list[str], now: float, settled_from: float
) -> None:
    living = [m for m in members if m.alive]
    for s in sources:
        believers = [m.name for m in living if m.holding.holds(s, now)]
        assert len(believers) <= 1, (now, s, believers)
    if now < settled_from + LEASE + 2 * PERIOD + LATENCY:
        return
    working = [m for m in living if now >= m.stalled_until]
    share = quota(len(sources), len(working))
    for s in sources:
        holder = tables.leases[s].holder
        owners = [m.name for m in working if m.holding.holds(s, now)]
        assert owners == [holder], (now, s, holder, owners)
    for m in working:
        assert len(m.holding.held(now)) <= share, (now, m.name, share)


@settings(max_examples=300, deadline=None)
@given(
    n_sources=st.integers(1, 14),
    phases=st.lists(st.floats(0.0, PERIOD), min_size=1, max_size=4),
    events=st.lists(disturbances, max_size=5),
    lags=st.lists(st.floats(0.0, LATENCY), min_size=1, max_size=5),
)
def test_one_holder_each_and_every_source_held_after_a_disturbance(
    n_sources: int, phases: list[float], events: list[Disturbance], lags: list[float]
) -> None:
    _run(n_sources, phases, events, lags)


def test_three_members_split_nine_sources_three_each() -> None:
    sources = [f"s{i}" for i in range(9)]
    tables = Tables(sources)
    members = [Member(f"m{i}", 0.0) for i in range(3)]
    for step in range(4):  # the first takes all; the next turns hand them over
        for m in members:
            m.turn(tables, sources, step * PERIOD, 0.0)
    assert sorted(len(m.holding.held(3 * PERIOD)) for m in members) == [3, 3, 3]


def test_plan_keeps_its_preferred_sources_and_releases_the_rest() -> None:
    leases = {s: Lease("a", 10.0) for s in ("x", "y", "z", "w")}
    todo = plan("a", ["x", "y", "z", "w"], leases, {"a": 10.0, "b": 10.0}, now=5.0)
    assert todo.quota == 2 and todo.want == 0 and not todo.take
    ranked = sorted("xyzw", key=lambda s: -preference("a", s))
    assert todo.keep == tuple(ranked[:2]) and todo.release == tuple(ranked[2:])


def test_plan_takes_expired_and_free_sources_never_live_ones() -> None:
    leases = {"x": Lease("b", 4.0), "y": Lease("b", 9.0), "z": Lease(None, 0.0)}
    todo = plan("a", ["x", "y", "z"], leases, {"b": 4.0}, now=5.0)  # b's row ran out
    assert set(todo.take) == {"x", "z"} and todo.want == 3 and todo.quota == 3


def test_default_lease_is_half_the_shortest_interval_within_1_and_30_s() -> None:
    assert default_lease([60.0, 10.0]) == 5.0
    assert default_lease([0.5]) == 1.0
    assert default_lease([600.0]) == 30.0
    assert default_lease([]) == 30.0
