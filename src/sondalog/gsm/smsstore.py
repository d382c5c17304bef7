"""The modem's SMS store, memory ``"SM"`` (3GPP TS 27.005 §3.1: ``<stat>``, ``<index>``).

Indexes run from 1 to the capacity; a new SMS takes the lowest free one. Status follows
27.005: received unread, received read (after ``AT+CMGR``/``AT+CMGL`` read it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from sondalog.gsm.pdu import Concat

REC_UNREAD = 0
REC_READ = 1
STO_UNSENT = 2
STO_SENT = 3
ALL = 4

#: ``<stat>`` as text mode names it, by its PDU mode number.
STAT_TEXT = {
    REC_UNREAD: "REC UNREAD",
    REC_READ: "REC READ",
    STO_UNSENT: "STO UNSENT",
    STO_SENT: "STO SENT",
    ALL: "ALL",
}
STAT_NUMBER = {text: number for number, text in STAT_TEXT.items()}


@dataclass(frozen=True, slots=True)
class StoredSms:
    sender: str
    text: str
    timestamp: int
    alphabet: str = "gsm7"
    concat: Concat | None = None
    status: int = REC_UNREAD


class SmsStore:
    """A fixed number of slots holding received SMS."""

    def __init__(self, capacity: int = 30) -> None:
        self.capacity = capacity
        self._slots: dict[int, StoredSms] = {}

    def __len__(self) -> int:
        return len(self._slots)

    @property
    def full(self) -> bool:
        return len(self._slots) >= self.capacity

    def add(self, sms: StoredSms) -> int | None:
        """Store ``sms`` in the lowest free slot; ``None`` when the store is full."""
        for index in range(1, self.capacity + 1):
            if index not in self._slots:
                self._slots[index] = sms
                return index
        return None

    def get(self, index: int) -> StoredSms | None:
        return self._slots.get(index)

    def mark_read(self, index: int) -> None:
        sms = self._slots.get(index)
        if sms is not None and sms.status == REC_UNREAD:
            self._slots[index] = replace(sms, status=REC_READ)

    def delete(self, index: int) -> None:
        self._slots.pop(index, None)

    def delete_where(self, statuses: set[int]) -> None:
        for index in [i for i, s in self._slots.items() if s.status in statuses]:
            del self._slots[index]

    def listing(self, stat: int) -> list[tuple[int, StoredSms]]:
        """Slots with status ``stat`` (or every slot for :data:`ALL`), by index."""
        return sorted((i, s) for i, s in self._slots.items() if stat in (ALL, s.status))

    def in_range(self, index: int) -> bool:
        return 1 <= index <= self.capacity
