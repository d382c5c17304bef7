"""Which notification goes to which destination, and when (issue 21); sans-I/O.

- Raised and cleared both notify every destination of the rule's ``notify``; acknowledging
  does not (it stops the repeats).
- ``repeat``: a raised, unacknowledged alarm is notified again every ``repeat`` seconds
  after its raise (:meth:`Policy.repeats`, driven by the clock like the timers). After a
  long stop only the latest repeat is sent, not every one missed.
- ``quiet`` windows hold a destination's notifications until the window ends (they go out
  then, oldest first), or drop them with ``quiet_mode = "drop"`` (kept as ``dropped`` in the
  outbox's history). Holding is the default: an alarm is not lost because it came at night.
- ``rate = "5/h"``: at most 5 messages per destination per clock hour; the rest of that
  hour goes out as ONE summary when the hour ends (its rows are kept as ``summarized``).
- A failed delivery is retried with the destination's backoff (10 s doubling to 1 h by
  default) until ``retries`` are used up (default: for ever); nothing is dropped silently.

Every notification is an outbox row keyed ``EVENT/WHAT/DESTINATION`` (:mod:`.outbox`), so
computing it twice stores it once: the policy itself keeps no state of its own.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from datetime import UTC, tzinfo
from typing import Any

from .events import AlarmRecord, Transition
from .outbox import Message, Outbox, What
from .rules import AlarmPlan, Notify

#: How long a sender may hold a claimed row before another may take it.
LEASE = 120.0


class Policy:
    """Turns transitions and the clock into outbox rows; ``zone``: the time zone of quiet
    windows of destinations that name none (the collector's local zone)."""

    def __init__(self, plan: AlarmPlan, outbox: Outbox, zone: tzinfo = UTC) -> None:
        self.plan = plan
        self.outbox = outbox
        self.zone = zone

    def _destinations(self, rule: str) -> list[Notify[Any]]:
        found = self.plan.rule(rule)
        if found is None:
            return []
        return [self.plan.notify[name] for name in found.notify]

    def notify(self, transitions: Iterable[Transition], now: float) -> list[Message]:
        """The rows ``transitions`` add to the outbox (raised and cleared ones)."""
        out: list[Message] = []
        for t in transitions:
            if t.what == "acknowledged":
                continue
            what: What = "raised" if t.what == "raised" else "cleared"
            for dest in self._destinations(t.rule):
                message = self._message(dest, what, t.event, t, now)
                if message is not None:
                    out.append(message)
        return out

    def repeats(self, active: Iterable[AlarmRecord], now: float) -> list[Message]:
        """The repeats due by ``now`` for raised, unacknowledged alarms."""
        out: list[Message] = []
        for record in active:
            if record.state != "raised" or record.raised_at is None or record.event is None:
                continue
            for dest in self._destinations(record.rule):
                if dest.repeat is None:
                    continue
                n = int((now - record.raised_at) // dest.repeat)
                if n < 1:
                    continue
                message = self._message(dest, "repeat", record.event, record, now, n)
                if message is not None:
                    out.append(message)
        return out

    def next_repeat(self, active: Iterable[AlarmRecord], now: float) -> float | None:
        """When :meth:`repeats` has the next repeat to add."""
        times = []
        for record in active:
            if record.state != "raised" or record.raised_at is None:
                continue
            for dest in self._destinations(record.rule):
                if dest.repeat is not None:
                    n = int((now - record.raised_at) // dest.repeat) + 1
                    times.append(record.raised_at + n * dest.repeat)
        return min(times, default=None)

    def _message(
        self,
        dest: Notify[Any],
        what: What,
        event: str,
        source: Transition | AlarmRecord,
        now: float,
        n: int = 0,
    ) -> Message | None:
        key = f"{event}/{what}{n if n else ''}/{dest.name}"
        if self.outbox.has(key):
            return None
        text = source.text if what != "repeat" else f"still raised: {source.text}"
        time = source.time if isinstance(source, Transition) else source.raised_at
        message = Message(
            key=key,
            destination=dest.name,
            what=what,
            event=event,
            text=text,
            created=now,
            next_try=now,
            alarm=source.alarm,
            rule=source.rule,
            subject=source.subject,
            value=source.value,
            time=time,
        )
        quiet_end = dest.quiet_until(now, self.zone) if dest.quiet else None
        if quiet_end is not None:
            if dest.quiet_mode == "drop":
                message = replace(message, state="dropped")
                self.outbox.add(message)
                return message
            message = replace(message, next_try=quiet_end)
        rate = dest.rate
        if rate is not None and self.outbox.count_since(dest.name, rate.start(now)) >= rate.count:
            summary = f"summary-{rate.window(now)}/summary/{dest.name}"
            line = f"{what}: {text}"
            if self.outbox.extend_summary(summary, line) or self.outbox.add(
                Message(
                    key=summary,
                    destination=dest.name,
                    what="summary",
                    event=f"summary-{rate.window(now)}",
                    text=line,
                    created=now,
                    next_try=max(rate.end(now), quiet_end or 0.0),
                )
            ):
                message = replace(message, state="summarized")
        self.outbox.add(message)
        return message

    def failed(self, message: Message, now: float, error: str) -> None:
        """Record a failed delivery of ``message``: retry after the backoff, or give up
        when the destination's ``retries`` are used up."""
        dest = self.plan.notify.get(message.destination)
        attempts = message.attempts + 1
        if dest is None or (dest.retries is not None and attempts >= dest.retries):
            self.outbox.failed(message.key, now, error, None)
        else:
            self.outbox.failed(message.key, now, error, now + dest.retry_delay(attempts))
