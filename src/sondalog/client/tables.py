"""Conversion tables on the host (§10.2-§10.4): read a folder, check, push, pull, explain.

``push`` checks every table before anything is sent (numbers, ascending inputs, names of at
most 10 characters, sizes against the memory partition), builds the list and data files,
uploads both by XMODEM and reads them back to verify. ``check`` tells, for each channel of a
logger, whether the tables it names are there and usable, and if not, why.

Progress: ``progress(phase, done, total)`` (total 0 when unknown) for every phase of the
work: ``upload list``, ``upload data``, ``check list``, ``check data`` for a push;
``download list``, ``download data`` for a pull (the data's size is known from the list).
Each phase reports ``done = 0`` first and ``done = total`` last; ``done`` counts bytes the
other side has taken (acknowledged or verified blocks, see :mod:`sondalog.client.transfer`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from sondalog.client.ala1 import Ala1Client
from sondalog.client.transfer import Progress, TransferFailed, download, upload
from sondalog.protocol.tables import (
    Surface,
    TableError,
    build_files,
    parse_list,
    parse_table,
    split_tables,
)

MAX_NAME = 10
#: ``progress(phase, done, total)``, see the module docstring.
PhaseProgress = Callable[[str, int, int], None]


def _phase(progress: PhaseProgress | None, name: str, total: int) -> Progress | None:
    """Announce phase ``name`` and return the byte-level callback of its transfer."""
    if progress is None:
        return None
    progress(name, 0, total)
    return lambda done, known: progress(name, done, known or total)


class TableProblem(ValueError):
    """Tables that must not be sent; ``problems`` lists every reason, one per line."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


def read_folder(folder: Path) -> dict[str, bytes]:
    """Every regular file of ``folder`` (sorted) as a table named after its stem."""
    if not folder.is_dir():
        raise TableProblem([f"{folder}: not a folder"])
    tables: dict[str, bytes] = {}
    problems: list[str] = []
    for path in sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")):
        name = path.stem
        if not name or len(name) > MAX_NAME or not name.isprintable() or " " in name:
            problems.append(f"{path}: a table name is 1 to {MAX_NAME} characters without spaces")
            continue
        if name in tables:
            problems.append(f"{path}: a second table named {name!r}")
            continue
        body = path.read_bytes()
        try:
            parse_table(body.decode("latin-1"))
        except TableError as exc:
            problems.append(f"{path}: {exc}")
        tables[name] = body
    if not tables and not problems:
        problems.append(f"{folder}: no table files")
    if problems:
        raise TableProblem(problems)
    return tables


@dataclass(frozen=True)
class Partition:
    list_size: int
    data_size: int


async def partition(client: Ala1Client) -> Partition:
    response = await client.command("read file list size read file data size")
    response.raise_for_error()
    sizes = [int(line) for line in response.lines]
    return Partition(sizes[0], sizes[1])


def check_fits(tables: dict[str, bytes], part: Partition) -> tuple[bytes, bytes]:
    """The list and data files, or TableProblem when they do not fit the partition."""
    listing, data = build_files(tables)
    problems = []
    if len(listing) > part.list_size:
        problems.append(
            f"the table list needs {len(listing)} bytes; file list size is {part.list_size}"
            " (write file list size, §6.15.2)"
        )
    if len(data) > part.data_size:
        problems.append(
            f"the tables need {len(data)} bytes; file data size is {part.data_size}"
            " (write file data size, §6.15.3)"
        )
    if problems:
        raise TableProblem(problems)
    return listing, data


async def push(
    client: Ala1Client, tables: dict[str, bytes], progress: PhaseProgress | None = None
) -> tuple[bytes, bytes]:
    """Upload ``tables`` (already checked by :func:`read_folder`) and verify them."""
    listing, data = check_fits(tables, await partition(client))
    for area, body in (("list", listing), ("data", data)):
        bar = _phase(progress, f"upload {area}", len(body))
        await upload(client, f"write special file {area} xmodem", body, bar)
        if progress is not None:
            progress(f"upload {area}", len(body), len(body))
    got_list, got_data = await pull_files(client, progress, expect=(listing, data))
    if got_list != listing or got_data != data:
        raise TransferFailed("the tables read back differ from the ones sent")
    return listing, data


async def pull_files(
    client: Ala1Client,
    progress: PhaseProgress | None = None,
    *,
    expect: tuple[bytes, bytes] | None = None,
) -> tuple[bytes, bytes]:
    """The list and data areas, padding removed using the list's lengths (§10.4).

    ``expect``: the files just sent (a push's read-back check: phases ``check ...``).
    """
    verb = "download" if expect is None else "check"
    known = None if expect is None else len(expect[0])
    bar = _phase(progress, f"{verb} list", known or 0)
    raw = await download(client, "read special file list xmodem", bar, expected=known)
    listing = raw.rstrip(b"\x1a")
    if progress is not None:
        progress(f"{verb} list", len(listing), len(listing))
    try:
        total: int | None = sum(length for _, length in parse_list(listing))
    except TableError:
        total = None
    bar = _phase(progress, f"{verb} data", total or 0)
    data = await download(client, "read special file data xmodem", bar, expected=total)
    if total is None or total > len(data):
        data = data.rstrip(b"\x1a")
    else:
        data = data[:total]
    if progress is not None:
        progress(f"{verb} data", len(data), len(data))
    return listing, data


async def pull(client: Ala1Client, progress: PhaseProgress | None = None) -> dict[str, bytes]:
    listing, data = await pull_files(client, progress)
    return split_tables(listing, data)


async def explain(client: Ala1Client) -> list[str]:
    """For every channel that names a table: whether it can be used, and why not (§6.5.12)."""
    listing, data = await pull_files(client)
    try:
        tables = split_tables(listing, data)
        list_error = None
    except TableError as exc:
        tables, list_error = {}, str(exc)
    count = int((await client.command("read channel max number")).raise_for_error().lines[0])
    report = []
    for ch in range(1, count + 1):
        response = await client.command(
            f"read channel {ch} type read channel {ch} convert 1 file name "
            f"read channel {ch} convert 2 file name"
        )
        kind, first, second = response.raise_for_error().lines
        for number, name in ((1, first), (2, second)):
            if not name:
                continue
            where = f"channel {ch} table {number} {name!r}"
            if list_error is not None:
                report.append(f"{where}: no value: the table list is broken: {list_error}")
            elif name not in tables:
                report.append(f"{where}: no value: no such table in the logger")
            else:
                try:
                    table = parse_table(tables[name].decode("latin-1"))
                except TableError as exc:
                    report.append(f"{where}: no value: {exc}")
                    continue
                two_d = number == 1 and kind == "9"
                if isinstance(table, Surface) != two_d:
                    need = "a 2-D table (type 9)" if two_d else "a 1-D table"
                    report.append(f"{where}: no value: the channel needs {need}")
                else:
                    report.append(f"{where}: ok")
    return report
