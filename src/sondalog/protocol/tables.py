"""Conversion tables (§6.5.12, §10): files, parsing, 1-D and 2-D interpolation.

The memory's list area holds lines ``name length`` and the data area the tables one after
another in list order (§10.4). A table is text: a 1-D table is lines of two numbers, input
ascending (§10.2); a 2-D table has one-number lines (the second input, the parameter) each
opening a region of two-number lines (§10.3). Line ends may be LF or CRLF.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from itertools import pairwise


class TableError(ValueError):
    """A table or the table list does not parse; channels using it yield no value."""


@dataclass(frozen=True)
class Curve:
    """A 1-D table: ascending inputs and their outputs (§10.2)."""

    xs: tuple[float, ...]
    ys: tuple[float, ...]

    def __call__(self, x: float) -> float:
        xs, ys = self.xs, self.ys
        if x <= xs[0]:
            return ys[0]
        if x >= xs[-1]:
            return ys[-1]
        i = bisect.bisect_right(xs, x)
        x0, x1, y0, y1 = xs[i - 1], xs[i], ys[i - 1], ys[i]
        return y0 + (y1 - y0) * (x - x0) / (x1 - x0)


@dataclass(frozen=True)
class Surface:
    """A 2-D table: one curve per value of the second input (§10.3)."""

    params: tuple[float, ...]
    curves: tuple[Curve, ...]

    def __call__(self, x: float, p: float) -> float:
        params, curves = self.params, self.curves
        if p <= params[0]:
            return curves[0](x)
        if p >= params[-1]:
            return curves[-1](x)
        i = bisect.bisect_right(params, p)
        p0, p1 = params[i - 1], params[i]
        y0, y1 = curves[i - 1](x), curves[i](x)
        return y0 + (y1 - y0) * (p - p0) / (p1 - p0)


Table = Curve | Surface


def _numbers(line: str, lineno: int) -> list[float]:
    try:
        return [float(part) for part in line.split()]
    except ValueError as exc:
        raise TableError(f"line {lineno}: not a number in {line!r}") from exc


def _curve(points: list[tuple[float, float]], where: str) -> Curve:
    if not points:
        raise TableError(f"{where}: no rows")
    xs = tuple(p[0] for p in points)
    if any(b <= a for a, b in pairwise(xs)):
        raise TableError(f"{where}: inputs must ascend")
    return Curve(xs, tuple(p[1] for p in points))


def parse_table(text: str) -> Table:
    """Parse one table file; a table with any one-number line is 2-D."""
    rows = [
        (lineno, _numbers(line, lineno))
        for lineno, line in enumerate(text.replace("\r\n", "\n").split("\n"), start=1)
        if line.strip()
    ]
    if not rows:
        raise TableError("empty table")
    if any(len(numbers) not in (1, 2) for _, numbers in rows):
        bad = next(lineno for lineno, numbers in rows if len(numbers) not in (1, 2))
        raise TableError(f"line {bad}: a row has one or two numbers")
    if all(len(numbers) == 2 for _, numbers in rows):
        return _curve([(n[0], n[1]) for _, n in rows], "table")
    if len(rows[0][1]) != 1:
        raise TableError("line 1: a 2-D table starts with a parameter line")
    params: list[float] = []
    curves: list[Curve] = []
    points: list[tuple[float, float]] = []
    for _, numbers in rows:
        if len(numbers) == 1:
            if params:
                curves.append(_curve(points, f"parameter {params[-1]:g}"))
            params.append(numbers[0])
            points = []
        else:
            points.append((numbers[0], numbers[1]))
    curves.append(_curve(points, f"parameter {params[-1]:g}"))
    if any(b <= a for a, b in pairwise(params)):
        raise TableError("parameters must ascend")
    return Surface(tuple(params), tuple(curves))


def parse_list(listing: bytes) -> list[tuple[str, int]]:
    """The table list (§10.4): ``name length`` lines; names at most 10 characters."""
    entries = []
    text = listing.rstrip(b"\x1a").decode("latin-1")
    for lineno, line in enumerate(text.replace("\r\n", "\n").split("\n"), start=1):
        if not line.strip():
            continue
        parts = line.split()
        if len(parts) != 2 or not parts[1].isdigit():
            raise TableError(f"list line {lineno}: expected 'name length', got {line!r}")
        if len(parts[0]) > 10:
            raise TableError(f"list line {lineno}: name {parts[0]!r} longer than 10")
        entries.append((parts[0], int(parts[1])))
    return entries


def split_tables(listing: bytes, data: bytes) -> dict[str, bytes]:
    """Cut the data area into the tables the list names (§10.4)."""
    tables: dict[str, bytes] = {}
    offset = 0
    for name, length in parse_list(listing):
        if offset + length > len(data):
            raise TableError(f"table {name}: data area too short")
        tables[name] = data[offset : offset + length]
        offset += length
    return tables


def build_files(tables: dict[str, bytes]) -> tuple[bytes, bytes]:
    """The list and data files for ``tables`` (in order), as a host prepares them (§10.4)."""
    listing = "".join(f"{name} {len(body)}\n" for name, body in tables.items()).encode()
    return listing, b"".join(tables.values())


class TableSet:
    """The tables in the memory's file areas, parsed once per change (§6.5.12)."""

    def __init__(self, listing: bytes = b"", data: bytes = b"") -> None:
        self.error: str | None = None
        self.raw: dict[str, bytes] = {}
        self._parsed: dict[str, Table | TableError] = {}
        try:
            self.raw = split_tables(listing, data)
        except TableError as exc:
            self.error = str(exc)

    def get(self, name: str) -> Table | TableError:
        """The table ``name``, or the reason it cannot be used."""
        if name in self._parsed:
            return self._parsed[name]
        result: Table | TableError
        if self.error is not None:
            result = TableError(f"table list: {self.error}")
        elif name not in self.raw:
            result = TableError(f"no table named {name!r}")
        else:
            try:
                result = parse_table(self.raw[name].decode("latin-1"))
            except TableError as exc:
                result = TableError(f"table {name}: {exc}")
        self._parsed[name] = result
        return result
