"""Protocol versions, their limits, and the view of module state that commands work on."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from enum import Enum
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from sondalog.ala1.record import RecordMemory


class Version(Enum):
    """Communication protocol version (§1.1)."""

    V1_16 = "1.16"
    V2_10 = "2.10"


@dataclass(frozen=True, slots=True)
class Limits:
    """Counts that differ between protocol versions (spec notes §5)."""

    channels: int
    commands: int
    addresses: int
    messages: int
    addresses_per_message: int
    channel_address_max: int
    devices: int = 8
    outputs: int = 7


LIMITS: dict[Version, Limits] = {
    Version.V1_16: Limits(8, 4, 8, 2, 1, 0xFFFF),
    Version.V2_10: Limits(12, 40, 40, 40, 10, 0xFFFF_FFFF_FFFF_FFFF),
}

#: Total non-volatile memory of the module in bytes (spec notes §5, §10.1 example).
TOTAL_MEMORY = 1048576

#: Baud rates the serial interface accepts (§6.11.2).
BAUD_RATES = (300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)


@dataclass(frozen=True, slots=True)
class Identity:
    """What a module is: fixed at manufacture (§6.3.1-§6.3.4, spec notes §5)."""

    version: Version = Version.V2_10
    serial_number: str = "000001"
    device: str = "ALA1"

    @property
    def program(self) -> str:
        from sondalog import __version__

        return f"sondalog {__version__}"

    @property
    def limits(self) -> Limits:
        return LIMITS[self.version]


class Unavailable(Exception):
    """The command is valid but its behaviour arrives with a later issue: error response."""


class CommandError(Exception):
    """A command that parsed but cannot run (range, state): error response."""


class View(Protocol):
    """The module's parameters as one command line sees them (a transaction)."""

    identity: Identity
    record: RecordMemory

    def get(self, key: str) -> str:
        """The current value of a storage key (its default when never written)."""
        ...

    def set(self, key: str, value: str) -> None:
        """Stage a new value; it becomes durable when the whole line succeeds."""
        ...

    def reset(self, keep: tuple[str, ...]) -> None:
        """Stage a return of every parameter to its factory value, except ``keep``."""
        ...

    def now(self) -> datetime:
        """The module clock as this line sees it."""
        ...

    def set_clock(self, moment: datetime) -> None:
        """Stage a new module clock value."""
        ...

    def clear_record(self) -> None:
        """Stage the erasure of the record memory (§6.6.5.1, §6.15.1, §6.17.1)."""
        ...

    def start_transfer(self, area: str, *, reading: bool) -> None:
        """After this command the line carries an XMODEM transfer of ``area`` (§6.16)."""
        ...

    def move_point(self, key: str, value: str) -> None:
        """Move a last-read point (a ``shift`` read, §6.6.1.4); a message defers it until its
        delivery succeeded (§6.8.4.1)."""
        ...

    def run_message(self, number: int) -> None:
        """Start message ``number`` once the line succeeded (§6.14.8)."""
        ...

    def release_line(self) -> None:
        """The line that runs this command stops blocking messages (§6.11.8)."""
        ...

    def measure(self, ch: int) -> str:
        """Measure channel ``ch`` now, formatted; empty when it has no value (§6.5.8)."""
        ...

    def measure_many(self, channels: list[int]) -> list[str]:
        """:meth:`measure` of each of ``channels``, in order (§6.5.8)."""
        ...

    def append_row(self, row_type: int, body: str) -> None:
        """Stage a record row of type ``row_type`` stamped now (§9)."""
        ...

    def channel_state(self, ch: int) -> tuple[str, str]:
        """The last scheduled sample and the last recorded value of a channel (§6.5.9)."""
        ...
