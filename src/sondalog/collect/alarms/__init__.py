"""Alarms and notifications of the collector (issue 21): the pure core and its store.

- :func:`parse_alarms` (:mod:`.parse`): ``[[alarm]]`` and ``[[notify]]`` of the collector's
  file -> :class:`AlarmPlan`, through the typed config reader;
- :class:`Alarms` (:mod:`.evaluate`): observations (:class:`Sample` or the collector's
  readings straight by ``ingest``, :class:`Contact`, :class:`Health`, :class:`Condition`)
  in, transitions (:class:`Raised`, :class:`Cleared`, :class:`Acknowledged`) out; timers by
  ``advance(now)``/``next_deadline()``; changed states out as :class:`StateChanges`;
- :class:`Policy` (:mod:`.policy`): transitions and the clock -> outbox rows (repeat, quiet
  windows, rate limit with one summary, retry with backoff);
- :class:`AlarmStore` (:mod:`.store`): states, history and outbox on SQLite;
  :class:`MemoryOutbox` the outbox in memory.

Sans-I/O like the device cores: no clock is read, nothing is sent here. docs/alarms.md.
"""

from .evaluate import Alarms
from .events import (
    Acknowledged,
    AlarmRecord,
    Cleared,
    Condition,
    Contact,
    Health,
    Raised,
    Sample,
    StateChanges,
    Transition,
    alarm_id,
)
from .outbox import MemoryOutbox, Message, Outbox
from .parse import parse_alarms
from .policy import LEASE, Policy
from .rules import AlarmPlan, Notify, Rule
from .store import AlarmStore

__all__ = [
    "LEASE",
    "Acknowledged",
    "AlarmPlan",
    "AlarmRecord",
    "AlarmStore",
    "Alarms",
    "Cleared",
    "Condition",
    "Contact",
    "Health",
    "MemoryOutbox",
    "Message",
    "Notify",
    "Outbox",
    "Policy",
    "Raised",
    "Rule",
    "Sample",
    "StateChanges",
    "Transition",
    "alarm_id",
    "parse_alarms",
]
