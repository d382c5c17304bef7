"""What the alarm core is fed and what it answers (issue 21), as plain typed values.

In: a :class:`Sample` (one reading of a channel), a :class:`Contact` (a source contacted,
well or not), a :class:`Health` sample of a logger, a :class:`Condition` of the collector
itself. Out: :class:`Raised`, :class:`Cleared` and :class:`Acknowledged` transitions. Every
time is seconds since the epoch (UTC) and is the observation's own: a download of old rows
raises and clears with the rows' times, not the collector's clock.

An alarm is one (rule, subject) pair: ``subject`` is ``LOGGER/CHANNEL`` for readings, the
logger (or source) for health, the source for contacts, the sink for the collector's sinks.
Its :class:`AlarmRecord` is what the store keeps, so a restart neither forgets nor repeats.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, fields
from datetime import UTC, datetime, timedelta
from operator import attrgetter
from typing import TYPE_CHECKING, Any, ClassVar, Literal

if TYPE_CHECKING:
    from sondalog.collect.model import Reading

State = Literal["ok", "raised", "acknowledged", "cleared"]
#: The states of an alarm that is on (shown, repeated until acknowledged).
ACTIVE: tuple[State, ...] = ("raised", "acknowledged")


def alarm_id(rule: str, subject: str) -> str:
    """The alarm's short id (``sondalog alarms ack FILE ID``): stable across restarts and
    the same in every collector that shares a store."""
    return hashlib.sha1(f"{rule}\0{subject}".encode()).hexdigest()[:10]


def event_key(alarm: str, raised_at: float) -> str:
    """One raise of an alarm (the idempotency key of its notifications): the alarm and the
    raise's own time, so two collectors that see the same readings name it alike."""
    return f"{alarm}-{round(raised_at * 1000)}"


@dataclass(frozen=True, slots=True)
class Sample:
    """One reading: ``value`` None (no valid value) is ignored. ``counter`` orders readings
    of the same second (the row's ``.c``)."""

    source: str
    logger: str
    channel: int
    value: float | None
    time: float
    name: str | None = None
    counter: int = 0

    @classmethod
    def of(cls, source: str, reading: Reading) -> Sample:
        """The collector's reading as a sample (what :meth:`Alarms.ingest` sees)."""
        return cls(
            source,
            reading.logger,
            reading.channel,
            reading.value,
            reading_time(reading),
            reading.name,
            reading.counter,
        )


def reading_time(reading: Reading) -> float:
    """A reading's time in seconds since the epoch: its UTC time when the logger's zone is
    known, else its own clock read as UTC. The same number as ``.timestamp()`` (both divide
    the microseconds since the epoch by a million), without a datetime made each time."""
    utc = reading.utc
    if utc is not None:
        return (utc - _EPOCH) / _SECOND
    return (reading.time - _NAIVE_EPOCH) / _SECOND


_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
_NAIVE_EPOCH = datetime(1970, 1, 1)
_SECOND = timedelta(seconds=1)


@dataclass(frozen=True, slots=True)
class Contact:
    """A contact of ``source`` that worked (``ok``) or failed (with the ``error``).

    ``heard`` is for message sources (a mailbox, the GSM network): whether the contact
    brought anything from a logger. A mailbox that answers while its loggers are silent (out
    of coverage) is not a contact with them: it neither clears nor restarts a
    ``no_contact`` alarm, though it is a good contact for ``watch = "source"``."""

    source: str
    ok: bool
    time: float
    error: str | None = None
    heard: bool = True


@dataclass(frozen=True, slots=True)
class Health:
    """A logger's health as a contact saw it; ``None``: not known this time."""

    source: str
    time: float
    logger: str | None = None
    supply: float | None = None  # volts
    memory: float | None = None  # record memory fill ratio 0..1
    clock: float | None = None  # logger clock minus collector clock, seconds
    signal: float | None = None  # GSM signal
    credit: float | None = None  # SIM credit
    gaps: float | None = None  # rows this download found lost from the record
    drift: float | None = None  # settings that differ from the source's expect file

    def measure(self, name: str) -> float | None:
        value: float | None = getattr(self, name)
        return abs(value) if name == "clock" and value is not None else value


@dataclass(frozen=True, slots=True)
class Condition:
    """The collector's own condition: ``sink`` (value 1 down, 0 up) or ``buffer`` (batches
    waiting) of the sink named ``subject``."""

    watch: Literal["sink", "buffer"]
    subject: str
    value: float
    time: float


Observation = Sample | Contact | Health | Condition


@dataclass(frozen=True, slots=True)
class Transition:
    """An alarm changed state at ``time`` (the observation's time)."""

    what: ClassVar[Literal["raised", "cleared", "acknowledged"]]
    alarm: str
    event: str
    rule: str
    kind: str
    subject: str
    time: float
    value: float | None
    text: str


@dataclass(frozen=True, slots=True)
class Raised(Transition):
    what: ClassVar[Literal["raised"]] = "raised"


@dataclass(frozen=True, slots=True)
class Cleared(Transition):
    what: ClassVar[Literal["cleared"]] = "cleared"
    raised_at: float = 0.0


@dataclass(frozen=True, slots=True)
class Acknowledged(Transition):
    what: ClassVar[Literal["acknowledged"]] = "acknowledged"
    by: str = ""


@dataclass(slots=True)
class AlarmRecord:
    """An alarm's state with its times, and what its rule needs to go on after a restart
    (``count``, ``last_value``, the last observation's ``last_time``/``last_counter``, the
    timer's ``ref``): a row of ``alarm_states`` (its columns are these fields, in order).

    The one type of an alarm's state: the core (:class:`~.evaluate.Alarms`) keeps each alarm
    as one and changes it in place (:mod:`.kinds`); what it hands out (``export``,
    ``active``, ``get``) are copies (:meth:`copy`), so a reader never sees it change."""

    alarm: str
    rule: str
    kind: str
    subject: str
    state: State = "ok"
    event: str | None = None
    value: float | None = None
    text: str = ""
    since: float | None = None
    raised_at: float | None = None
    acked_at: float | None = None
    cleared_at: float | None = None
    count: int = 0
    last_value: float | None = None
    last_time: float | None = None
    last_counter: int = 0
    ref: float | None = None

    @property
    def active(self) -> bool:
        return self.state in ACTIVE

    def copy(self) -> AlarmRecord:
        """A copy that the core's later changes do not touch."""
        return AlarmRecord(*_record_values(self))

    def row(self) -> tuple[Any, ...]:
        """The record as a row of ``alarm_states`` (its fields, in order)."""
        row: tuple[Any, ...] = _record_values(self)
        return row

    def newer(self, time: float, counter: int = 0) -> bool:
        """Whether an observation at ``time`` comes after the last one (and note it):
        a reading seen twice (a data message, then the download) counts once."""
        if self.last_time is not None and (time, counter) <= (self.last_time, self.last_counter):
            return False
        self.last_time, self.last_counter = time, counter
        return True


_record_values = attrgetter(*(f.name for f in fields(AlarmRecord)))


@dataclass(frozen=True, slots=True)
class StateChanges:
    """Rows to write (:meth:`~.evaluate.Alarms.changes`): of ``alarm_states``, ``states``
    whole, ``counters`` only in their rule's progress columns (``count``, ``last_value``,
    ``last_time``, ``last_counter``; the rest of the row is as the store has it); of
    ``alarm_progress``, ``progress``: (logger, progress) of each logger whose reading alarms
    moved (:mod:`.progress`), in the order of the logger."""

    states: list[tuple[Any, ...]]
    counters: list[tuple[Any, ...]]
    progress: list[tuple[str, bytes]] = field(default_factory=list)
