"""What is sent to whom, and when (issue 21): raised and cleared, repeat, quiet windows,
the rate limit's one summary, retries with backoff, idempotent keys."""

from __future__ import annotations

from datetime import UTC, datetime

from alarm_helpers import T0, plan_of, sample

from sondalog.collect.alarms import Alarms, MemoryOutbox, Policy

DESTS = """
[[notify]]
name = "mail"
kind = "email"
smtp = "127.0.0.1:2525"
from = "c@example.net"
to = "ops@example.net"
repeat = "1h"
[[notify]]
name = "sms"
kind = "sms"
via = "network"
url = "http://127.0.0.1:8025"
from = "+420700000009"
number = "+420700000001"
rate = "3/h"
retries = 3
[[notify]]
name = "night"
kind = "log"
quiet = "22:00-06:00"
[[notify]]
name = "night-drop"
kind = "log"
quiet = "22:00-06:00"
quiet_mode = "drop"
"""


def setup(notify: str, extra: str = "") -> tuple[Alarms, Policy, MemoryOutbox]:
    plan = plan_of(
        DESTS
        + f"""
[[alarm]]
name = "hot"
kind = "threshold"
above = 40
notify = [{notify}]
"""
        + extra
    )
    outbox = MemoryOutbox()
    return Alarms(plan), Policy(plan, outbox), outbox


def test_raised_and_cleared_notify_each_destination_once() -> None:
    alarms, policy, outbox = setup('"mail", "sms"')
    made = policy.notify(alarms.reading(sample(41, 0)), T0)
    assert sorted(m.key.split("/", 1)[1] for m in made) == ["raised/mail", "raised/sms"]
    again = alarms.reading(sample(41, 0))  # the same reading: no transition
    assert policy.notify(again, T0) == []
    made = policy.notify(alarms.reading(sample(30, 60)), T0 + 60)
    assert [m.what for m in made] == ["cleared", "cleared"]
    assert all(m.event == made[0].event for m in made)  # same event as the raise
    due = outbox.claim(T0 + 60, "me", 60)
    assert len(due) == 4
    assert outbox.claim(T0 + 61, "other", 60) == []  # leased
    for m in due:
        outbox.delivered(m.key, T0 + 62)
    assert outbox.next_try() is None


def test_a_transition_computed_twice_is_stored_once() -> None:
    """Two collectors (or a restart) computing the same raise: the key is the same."""
    alarms, policy, outbox = setup('"mail"')
    [t] = alarms.reading(sample(41, 0))
    assert len(policy.notify([t], T0)) == 1
    assert policy.notify([t], T0 + 5) == []
    assert len(outbox.rows) == 1


def test_repeat_until_acknowledged() -> None:
    alarms, policy, _ = setup('"mail"')
    policy.notify(alarms.reading(sample(41, 0)), T0)
    assert policy.repeats(alarms.active(), T0 + 3599) == []
    assert policy.next_repeat(alarms.active(), T0) == T0 + 3600
    [rep] = policy.repeats(alarms.active(), T0 + 3600)
    assert rep.what == "repeat" and rep.text.startswith("still raised")
    assert policy.repeats(alarms.active(), T0 + 3700) == []  # once per period
    # after a long stop only the latest is sent
    assert len(policy.repeats(alarms.active(), T0 + 10 * 3600)) == 1
    alarms.acknowledge(alarms.active()[0].alarm, T0 + 36001)
    assert policy.repeats(alarms.active(), T0 + 20 * 3600) == []
    assert policy.next_repeat(alarms.active(), T0 + 20 * 3600) is None


def test_a_storm_becomes_one_summary() -> None:
    """1000 loggers cross at once: 3 SMS (the rate), then ONE summary at the hour's end."""
    alarms, policy, outbox = setup('"sms"')
    hour = (T0 // 3600) * 3600
    now = hour + 10
    for i in range(1000):
        policy.notify(alarms.reading(sample(41, 10, logger=f"F{i:04}")), now)
    pending = [m for m in outbox.rows.values() if m.state == "pending"]
    assert len(pending) == 4
    [summary] = [m for m in pending if m.what == "summary"]
    assert summary.items == 997 and summary.next_try == hour + 3600
    assert "... and" in summary.text and summary.text.count("\n") <= 21
    first = outbox.claim(now, "me", 60)
    assert len(first) == 3  # the summary waits for the hour's end
    for m in first:
        outbox.delivered(m.key, now)
    assert [m.what for m in outbox.claim(hour + 3600, "me", 60)] == ["summary"]
    summarized = [m for m in outbox.rows.values() if m.state == "summarized"]
    assert len(summarized) == 997  # kept for the history, never sent


def _at(hour: int, minute: int = 0) -> float:
    return datetime(2024, 3, 1, hour, minute, tzinfo=UTC).timestamp()


def test_quiet_window_holds_until_morning() -> None:
    alarms, policy, outbox = setup('"night"')
    [m] = policy.notify(alarms.reading(sample(41, _at(23) - T0)), _at(23))
    assert m.next_try == datetime(2024, 3, 2, 6, 0, tzinfo=UTC).timestamp()
    assert outbox.claim(_at(23, 30), "me", 60) == []
    assert len(outbox.claim(m.next_try, "me", 60)) == 1
    [day] = policy.notify(alarms.reading(sample(30, _at(12) + 86400 - T0)), _at(12) + 86400)
    assert day.next_try == day.created  # outside the window: at once


def test_quiet_window_drop_mode() -> None:
    alarms, policy, outbox = setup('"night-drop"')
    [m] = policy.notify(alarms.reading(sample(41, _at(3) - T0)), _at(3))
    assert m.state == "dropped"
    assert outbox.claim(_at(12), "me", 60) == [] and outbox.next_try() is None


def test_failed_delivery_is_retried_with_backoff_then_given_up() -> None:
    alarms, policy, outbox = setup('"sms", "mail"')
    policy.notify(alarms.reading(sample(41, 0)), T0)
    now = T0
    tries = []
    while (due := outbox.claim(now, "me", 60)) and len(tries) < 50:
        for m in due:
            if m.destination == "sms":
                policy.failed(m, now, "HTTP 503")
                tries.append(now)
            else:
                outbox.delivered(m.key, now)
        now = outbox.next_try() or now
    assert [t - T0 for t in tries] == [0, 10, 30]  # 10 s, then 20 s; retries = 3
    sms = next(m for m in outbox.rows.values() if m.destination == "sms")
    assert (sms.state, sms.attempts, sms.last_error) == ("failed", 3, "HTTP 503")
    mail = next(m for m in outbox.rows.values() if m.destination == "mail")
    assert mail.state == "sent"


def test_a_sender_killed_after_claiming_is_replaced_after_the_lease() -> None:
    alarms, policy, outbox = setup('"mail"')
    policy.notify(alarms.reading(sample(41, 0)), T0)
    [m] = outbox.claim(T0, "dead", 120)
    assert outbox.claim(T0 + 119, "other", 120) == []
    assert outbox.next_try() == T0 + 120
    [again] = outbox.claim(T0 + 120, "other", 120)
    assert again.key == m.key  # the same idempotency key
