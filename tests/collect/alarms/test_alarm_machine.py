"""The alarm core, policy and SQLite store against random interleavings (issue 21): readings
(some late), contacts, acknowledgements, clock steps, deliveries that fail, restarts.

Asserted all along: never two raises of an alarm without a clear between, and every
transition has one outbox row per destination of its rule (or is folded into the rate
limit's summary, whose count matches); a row that was delivered is never handed out again.
At the end, with every delivery succeeding, nothing stays queued."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from alarm_helpers import T0, plan_of
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from sondalog.collect.alarms import (
    Alarms,
    AlarmStore,
    Contact,
    Policy,
    Sample,
    Transition,
)

PLAN = plan_of(
    """
[[notify]]
name = "mail"
kind = "email"
smtp = "127.0.0.1:2525"
from = "c@example.net"
to = "ops@example.net"
repeat = "30m"
[[notify]]
name = "sms"
kind = "sms"
via = "network"
url = "http://127.0.0.1:8025"
from = "+420700000009"
number = "+420700000001"
rate = "3/h"
[[notify]]
name = "night"
kind = "log"
quiet = "22:00-06:00"

[[alarm]]
name = "hot"
kind = "threshold"
channel = 1
above = 40
clear = 38
for = 2
notify = ["mail", "sms", "night"]

[[alarm]]
name = "silent"
kind = "no_contact"
after = 900
notify = ["sms", "night"]
"""
)
LOGGERS = ("F1", "F2", "F3")
SOURCES = ("s1", "s2")
LEASE = 60.0
#: A RAM disk where there is one: the machine opens and closes stores thousands of times.
SHM = "/dev/shm" if Path("/dev/shm").is_dir() else None


class AlarmMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.dir = Path(tempfile.mkdtemp(prefix="alarms-", dir=SHM))
        self.now = T0
        self.last_contact = dict.fromkeys(SOURCES, T0)
        self.last: dict[str, str] = {}  # alarm -> the last transition's what
        self.expected: set[str] = set()  # outbox keys every transition must have made
        self.sent: set[str] = set()
        self._open()
        for source in SOURCES:
            self.alarms.watch_source(source, 300, now=self.now, last_contact=T0)

    def _open(self) -> None:
        self.store = AlarmStore(self.dir / "alarms.sqlite").open()
        self.alarms = Alarms(PLAN, self.store.load_states())
        self.policy = Policy(PLAN, self.store)

    def _commit(self, out: list[Transition]) -> None:
        for t in out:
            if t.what == "acknowledged":
                assert self.last.get(t.alarm) == "raised"
                continue
            previous = self.last.get(t.alarm, "cleared")
            assert previous != t.what, f"two {t.what} of {t.subject} without the other"
            self.last[t.alarm] = t.what
            rule = PLAN.rule(t.rule)
            assert rule is not None
            self.expected |= {f"{t.event}/{t.what}/{d}" for d in rule.notify}
        with self.store.transaction():
            self.store.record(out)
            self.policy.notify(out, self.now)
            self.policy.repeats(self.alarms.active(), self.now)
            self.store.save_states(self.alarms.changed())

    @rule(
        logger=st.sampled_from(LOGGERS),
        value=st.sampled_from([30.0, 37.0, 39.0, 41.0, 45.0]),
        lag=st.sampled_from([0.0, 0.0, 0.0, 600.0, 7200.0]),
    )
    def reading(self, logger: str, value: float, lag: float) -> None:
        self.now += 1
        sample = Sample("s1", logger, 1, value, self.now - lag)
        self._commit(self.alarms.reading(sample))

    @rule(source=st.sampled_from(SOURCES), ok=st.booleans())
    def contact(self, source: str, ok: bool) -> None:
        self.now += 1
        if ok:
            self.last_contact[source] = self.now
        self._commit(self.alarms.contact(Contact(source, ok, self.now)))

    @rule(dt=st.sampled_from([10.0, 300.0, 1000.0, 3600.0, 6 * 3600.0]))
    def tick(self, dt: float) -> None:
        self.now += dt
        self._commit(self.alarms.advance(self.now))

    @precondition(lambda self: bool(self.alarms.active()))
    @rule(pick=st.integers(0, 10))
    def acknowledge(self, pick: int) -> None:
        active = self.alarms.active()
        ack = self.alarms.acknowledge(active[pick % len(active)].alarm, self.now, "ops")
        self._commit([ack] if ack is not None else [])

    @rule(ok=st.booleans())
    def deliver(self, ok: bool) -> None:
        for m in self.store.claim(self.now, "me", LEASE):
            assert m.key not in self.sent, f"{m.key} handed out after it was sent"
            if ok:
                self.store.delivered(m.key, self.now)
                self.sent.add(m.key)
            else:
                self.policy.failed(m, self.now, "down")

    @rule()
    def restart(self) -> None:
        self.store.close()
        self._open()
        for source in SOURCES:
            self.alarms.watch_source(
                source, 300, now=self.now, last_contact=self.last_contact[source]
            )
        self._commit([])

    @invariant()
    def every_transition_has_its_rows(self) -> None:
        rows = {m.key: m for m in self.store.messages()}
        missing = self.expected - rows.keys()
        assert not missing, missing
        summarized: dict[str, int] = {}
        for m in rows.values():
            if m.state == "summarized":
                window = int(m.created // 3600)
                key = f"summary-{window}/summary/{m.destination}"
                summarized[key] = summarized.get(key, 0) + 1
        for key, n in summarized.items():
            assert rows[key].items == n, (key, rows[key].items, n)

    def teardown(self) -> None:
        try:
            for _ in range(100):  # every delivery works now: the outbox drains
                due = self.store.next_try()
                if due is None:
                    break
                self.now = max(self.now, due)
                self.deliver(True)
            assert self.store.next_try() is None, "queued for ever"
            assert not [m for m in self.store.messages() if m.state == "pending"]
        finally:
            self.store.close()
            shutil.rmtree(self.dir, ignore_errors=True)


AlarmMachine.TestCase.settings = settings(
    max_examples=60,
    stateful_step_count=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
TestAlarmMachine = AlarmMachine.TestCase
