"""``read|write special ... xmodem`` (§6.16, §10.4): what is sent, and applying what arrived.

A transfer replaces a file area, the record or the program only when it completed; a failed
or cancelled transfer changes nothing. Padding (0x1A) is removed using the lengths in the
table list (§10.4).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from sondalog.ala1.model import CommandError
from sondalog.ala1.params import RESET_KEEPS
from sondalog.ala1.state import ModuleState
from sondalog.protocol.tables import TableError, parse_list

SUB = 0x1A
#: First line of a sondalog program upgrade image (§6.16.4; docs/decisions.md).
UPGRADE_MAGIC = "sondalog-upgrade 1"
_ROW = re.compile(r"^\d{14}\.[0-9A-Z],[1-9],.*$")


@dataclass(frozen=True)
class TransferRequest:
    """What a ``special`` command asks of the line."""

    area: str  # "list", "data", "record" or "program"
    send: bytes | None  # read: the bytes the module sends; write: None
    max_size: int  # write: the largest accepted image


def request(state: ModuleState, area: str, reading: bool) -> TransferRequest:
    """The transfer for ``read|write special file AREA xmodem`` or ``special program``."""
    if area == "program":
        return TransferRequest(area, None, 65536)
    size = int(state.get(f"file {area} size"))
    if not reading:
        return TransferRequest(area, None, size)
    if area == "record":
        image = "".join(row + "\r\n" for row in state.record.rows()).encode("latin-1")
    else:
        image = state.store.load_files().get(area, b"")
    return TransferRequest(area, image, size)


def apply(state: ModuleState, area: str, data: bytes, host_now: float) -> None:
    """Store a completed upload; raises CommandError (nothing stored) when it is refused."""
    if area == "list":
        state.write_file("list", data.rstrip(bytes([SUB])))
    elif area == "data":
        state.write_file("data", _strip_data(state, data))
    elif area == "record":
        _replace_record(state, data, host_now)
    elif area == "program":
        _upgrade(state, data, host_now)
    else:  # pragma: no cover - the command table names only these
        raise CommandError(area)


def _strip_data(state: ModuleState, data: bytes) -> bytes:
    """§10.4: the data area holds the tables named in the list, one after another."""
    try:
        total = sum(length for _, length in parse_list(state.store.load_files().get("list", b"")))
    except TableError:
        return data.rstrip(bytes([SUB]))
    if total <= len(data):
        return data[:total]
    return data.rstrip(bytes([SUB]))


def _replace_record(state: ModuleState, data: bytes, host_now: float) -> None:
    """§6.16.3: writing the record area replaces the rows (the manual advises against it)."""
    text = data.rstrip(bytes([SUB])).decode("latin-1")
    rows = [row for row in text.split("\r\n") if row]
    if any(not _ROW.match(row) for row in rows):
        raise CommandError("the record image holds something that is not a row")
    if sum(len(row) + 2 for row in rows) > int(state.get("file record size")):
        raise CommandError("the rows do not fit the record")
    txn = state.begin(host_now)
    txn.clear_record()
    state.record.load_rows(rows)
    txn.commit()


def parse_upgrade(data: bytes) -> str:
    """The program version named by a sondalog upgrade image, or CommandError."""
    try:
        text = data.rstrip(bytes([SUB])).decode("ascii")
    except UnicodeDecodeError as exc:
        raise CommandError("not a sondalog upgrade image") from exc
    lines = text.replace("\r\n", "\n").split("\n")
    if not lines or lines[0].strip() != UPGRADE_MAGIC:
        raise CommandError("not a sondalog upgrade image")
    for line in lines[1:]:
        key, _, value = line.partition(":")
        if key.strip() == "program":
            version = value.strip()
            if 0 < len(version) <= 40 and version.isprintable():
                return version
    raise CommandError("the upgrade image names no program version")


def _upgrade(state: ModuleState, data: bytes, host_now: float) -> None:
    """§6.16.4: a new program; every parameter back to factory values except the three
    communication ones, and the record erased."""
    version = parse_upgrade(data)
    txn = state.begin(host_now)
    txn.reset(keep=RESET_KEEPS)
    txn.clear_record()
    txn.set("i program", version)
    txn.commit()
