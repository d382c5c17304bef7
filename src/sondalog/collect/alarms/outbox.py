"""The notification outbox (issue 21): one row per (alarm event, destination), sent
at least once, never twice on purpose.

- A row's ``key`` (``EVENT/WHAT/DESTINATION``) is unique: adding a row that exists does
  nothing, so a transition computed twice (a restart, two collectors on one PostgreSQL)
  notifies once. The key is also the webhook's idempotency key.
- Claim, then send: :meth:`Outbox.claim` hands out due rows and marks them taken until a
  lease runs out; :meth:`Outbox.delivered` marks a row sent. A sender killed between sending
  and marking sends again after the lease (at-least-once).
- A failed row waits ``next_try`` (backoff, :meth:`~.rules.Notify.retry_delay`) and is kept
  as ``failed`` once its destination's ``retries`` are used up; ``dropped`` (quiet window with
  ``quiet_mode = "drop"``) and ``summarized`` (folded into a rate-limit summary) rows are kept
  for the history but never sent.

:class:`MemoryOutbox` is the pure in-memory outbox; :class:`~.store.AlarmStore` is the same
on SQLite.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal, Protocol

MessageState = Literal["pending", "sent", "failed", "dropped", "summarized"]
What = Literal["raised", "cleared", "repeat", "summary"]
#: A summary lists at most this many notifications (then "... and N more").
SUMMARY_LINES = 20


@dataclass(frozen=True, slots=True)
class Message:
    """One notification to one destination (an outbox row)."""

    key: str
    destination: str
    what: What
    event: str
    text: str
    created: float
    next_try: float
    alarm: str | None = None
    rule: str | None = None
    subject: str | None = None
    value: float | None = None
    time: float | None = None  # the transition's own time
    items: int = 1
    state: MessageState = "pending"
    attempts: int = 0
    last_error: str | None = None
    sent_at: float | None = None
    claimed_by: str | None = None
    claimed_until: float | None = None

    @property
    def title(self) -> str:
        """A one-line title (e-mail subject)."""
        if self.what == "summary":
            return f"sondalog: {self.items} alarm notifications (rate limit)"
        return f"sondalog alarm {self.what.upper()}: {self.text}"


def add_line(text: str, items: int, line: str) -> str:
    """``text`` of a summary of ``items`` notifications with ``line`` added."""
    lines = text.split("\n")[:SUMMARY_LINES]
    if items < SUMMARY_LINES:
        return "\n".join([*lines, line])
    return "\n".join([*lines, f"... and {items + 1 - SUMMARY_LINES} more"])


class Outbox(Protocol):
    """What the notification policy and the senders need of an outbox."""

    def has(self, key: str) -> bool: ...

    def add(self, message: Message) -> bool:
        """Store ``message`` unless its key exists; whether it was stored."""
        ...

    def count_since(self, destination: str, since: float) -> int:
        """Rows to ``destination`` created since ``since`` that count against its rate
        (not summaries, not dropped or summarized ones)."""
        ...

    def extend_summary(self, key: str, line: str) -> bool:
        """Add ``line`` to the pending summary ``key``; False if there is none."""
        ...

    def claim(self, now: float, owner: str, lease: float, limit: int = 100) -> list[Message]:
        """Due pending rows (``next_try <= now``, not claimed by a live lease), claimed by
        ``owner`` until ``now + lease``."""
        ...

    def delivered(self, key: str, now: float) -> None: ...

    def failed(self, key: str, now: float, error: str, next_try: float | None) -> None:
        """A failed attempt: try again at ``next_try``, or give up (``None``)."""
        ...

    def next_try(self) -> float | None:
        """The earliest ``next_try`` of a pending row (a claimed one: its lease's end)."""
        ...

    def messages(self) -> Sequence[Message]: ...


class MemoryOutbox:
    """The outbox in memory (tests, and a collector without a store)."""

    def __init__(self) -> None:
        self.rows: dict[str, Message] = {}

    def has(self, key: str) -> bool:
        return key in self.rows

    def add(self, message: Message) -> bool:
        if message.key in self.rows:
            return False
        self.rows[message.key] = message
        return True

    def count_since(self, destination: str, since: float) -> int:
        return sum(
            1
            for m in self.rows.values()
            if m.destination == destination
            and m.created >= since
            and m.what != "summary"
            and m.state not in ("dropped", "summarized")
        )

    def extend_summary(self, key: str, line: str) -> bool:
        row = self.rows.get(key)
        if row is None or row.state != "pending" or row.claimed_by is not None:
            return False
        self.rows[key] = replace(row, text=add_line(row.text, row.items, line), items=row.items + 1)
        return True

    def claim(self, now: float, owner: str, lease: float, limit: int = 100) -> list[Message]:
        due = sorted(
            (m for m in self.rows.values() if _due(m, now)), key=lambda m: (m.next_try, m.key)
        )[:limit]
        out = []
        for m in due:
            taken = replace(m, claimed_by=owner, claimed_until=now + lease)
            self.rows[m.key] = taken
            out.append(taken)
        return out

    def delivered(self, key: str, now: float) -> None:
        row = self.rows[key]
        self.rows[key] = replace(
            row,
            state="sent",
            sent_at=now,
            attempts=row.attempts + 1,
            claimed_by=None,
            claimed_until=None,
        )

    def failed(self, key: str, now: float, error: str, next_try: float | None) -> None:
        row = self.rows[key]
        self.rows[key] = replace(
            row,
            state="pending" if next_try is not None else "failed",
            attempts=row.attempts + 1,
            last_error=error,
            next_try=next_try if next_try is not None else row.next_try,
            claimed_by=None,
            claimed_until=None,
        )

    def next_try(self) -> float | None:
        times = [
            max(m.next_try, m.claimed_until or m.next_try)
            for m in self.rows.values()
            if m.state == "pending"
        ]
        return min(times, default=None)

    def messages(self) -> list[Message]:
        return sorted(self.rows.values(), key=lambda m: (m.created, m.key))


def _due(m: Message, now: float) -> bool:
    return (
        m.state == "pending"
        and m.next_try <= now
        and (m.claimed_until is None or m.claimed_until <= now)
    )
