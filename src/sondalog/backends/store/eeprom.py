"""HCTMPS1 EEPROM images in SQLite (hctmps1.md §1, DESIGN.md point 5).

One database file per bus instance in its state directory, one row per module slot. A slot is
named after the module's *configured* (factory) ID, which never changes, while the ID stored
in the image may (``SETMID`` + ``SAVEEE``). The database runs in WAL mode with
``synchronous=FULL``: when :meth:`SqliteEeprom.save` returns, the commit is on disk, so the
module's ``RSAVEEE.<OK>`` never leaves before the data is durable; a kill -9 at any moment
leaves either the old or the new image.
"""

from __future__ import annotations

import json
from pathlib import Path

from sondalog.hctmps1.eeprom import EepromImage
from sondalog.io.private import connect_private, private_dir, private_parents

#: File name of the bus's EEPROM database inside the state directory.
FILE_NAME = "hctmps1-eeprom.sqlite3"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS eeprom (
    slot TEXT PRIMARY KEY,
    image TEXT NOT NULL,
    writes INTEGER NOT NULL DEFAULT 1
)
"""


class EepromDatabase:
    """The SQLite file holding every module's EEPROM of one bus instance."""

    def __init__(self, path: Path) -> None:
        self.path = path
        private_parents(path)
        self._db = connect_private(path)  # 0600, its -wal and -shm too (docs/security.md)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.execute(_SCHEMA)

    @classmethod
    def in_state_dir(cls, state_dir: Path) -> EepromDatabase:
        return cls(private_dir(state_dir) / FILE_NAME)

    def slot(self, name: str) -> SqliteEeprom:
        """The EEPROM of the module configured as ``name``."""
        return SqliteEeprom(self, name)

    def load(self, slot: str) -> EepromImage | None:
        row = self._db.execute("SELECT image FROM eeprom WHERE slot = ?", (slot,)).fetchone()
        if row is None:
            return None
        return EepromImage.from_dict(json.loads(row[0]))

    def save(self, slot: str, image: EepromImage) -> None:
        payload = json.dumps(image.to_dict(), sort_keys=True)
        with self._db:  # one transaction, committed (and synced) on exit
            self._db.execute("BEGIN IMMEDIATE")
            self._db.execute(
                "INSERT INTO eeprom (slot, image) VALUES (?, ?) ON CONFLICT (slot) DO UPDATE "
                "SET image = excluded.image, writes = writes + 1",
                (slot, payload),
            )

    def close(self) -> None:
        self._db.close()


class SqliteEeprom:
    """One module's EEPROM: an :class:`sondalog.hctmps1.EepromStore` backed by SQLite."""

    def __init__(self, database: EepromDatabase, slot: str) -> None:
        self.database = database
        self.slot = slot

    def load(self) -> EepromImage | None:
        return self.database.load(self.slot)

    def save(self, image: EepromImage) -> None:
        self.database.save(self.slot, image)
