"""The module's non-volatile settings and where they are kept (hctmps1.md §1).

The EEPROM holds the module ID, the password, the supervisor list and the measured
variable's symbol. The core reads it at power-up and on ``REINIT`` and writes it on
``SAVEEE`` through an :class:`EepromStore`; :class:`MemoryEeprom` keeps it in memory (tests,
a bus without ``--state``), :class:`sondalog.backends.store.eeprom.SqliteEeprom` in SQLite.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

#: Factory password (§1).
FACTORY_PASSWORD = "0000"
#: At most this many supervisors (§1).
MAX_SUPERVISORS = 8


@dataclass(frozen=True, slots=True)
class EepromImage:
    """The settings kept in non-volatile memory (§1)."""

    module_id: str
    password: str = FACTORY_PASSWORD
    supervisors: tuple[str, ...] = ()
    symbol: str | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "module_id": self.module_id,
            "password": self.password,
            "supervisors": list(self.supervisors),
            "symbol": self.symbol,
        }

    @classmethod
    def from_dict(cls, data: dict[str, object]) -> EepromImage:
        module_id = data["module_id"]
        password = data["password"]
        supervisors = data["supervisors"]
        symbol = data.get("symbol")
        if not (
            isinstance(module_id, str)
            and isinstance(password, str)
            and isinstance(supervisors, list)
            and all(isinstance(s, str) for s in supervisors)
            and (symbol is None or isinstance(symbol, str))
        ):
            raise ValueError(f"corrupt EEPROM image: {data!r}")
        return cls(module_id, password, tuple(supervisors), symbol)


class EepromStore(Protocol):
    """Where one module's EEPROM lives."""

    def load(self) -> EepromImage | None:
        """The saved image, or None if nothing was ever saved."""
        ...

    def save(self, image: EepromImage) -> None:
        """Write ``image``; it must be durable when this returns (DESIGN.md point 5)."""
        ...


@dataclass
class MemoryEeprom:
    """An EEPROM kept in memory: lost with the process."""

    image: EepromImage | None = None
    saves: list[EepromImage] = field(default_factory=list)

    def load(self) -> EepromImage | None:
        return self.image

    def save(self, image: EepromImage) -> None:
        self.image = image
        self.saves.append(image)
