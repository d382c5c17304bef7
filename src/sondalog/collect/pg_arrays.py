"""One-dimensional PostgreSQL arrays encoded in the binary format at once, as query
parameters (issue 24: the dashboard's block upsert, :mod:`.blocks_sql`).

psycopg dumps a list parameter in Python element by element (choosing each element's type
and packing it): for the few hundred blocks of a batch, eight arrays, that was the largest
single share of the collector's CPU on PostgreSQL. Here each array is one ``struct`` call
(lengths and elements interleaved), the loggers' names encoded once a call; the result is a
:class:`bytes` of a type whose dumper passes it as it is, binary, with the array's type, on
a connection that :func:`register` prepared. The same bytes as the binary ``COPY`` of
:mod:`.pg_rows` writes for a field; NUL characters, which PostgreSQL text cannot hold, are
dropped as there.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable, Sequence
from typing import ClassVar

import psycopg
from psycopg import adapt, pq

from sondalog.collect.pg_rows import FLOAT8, INT4, INT8, NULL, TEXT, clean

#: The array types of the element types.
_ARRAY_OF = {INT4: 1007, INT8: 1016, FLOAT8: 1022, TEXT: 1009}

_head = struct.Struct("!iiIii").pack  # ndim 1, has NULLs, element type, n, lower bound 1
_length = struct.Struct("!i").pack


class Array(bytes):
    """An array parameter already in the binary format (:func:`int4s` and the others)."""

    oid: ClassVar[int] = 0


class Int4s(Array):
    oid = _ARRAY_OF[INT4]


class Int8s(Array):
    oid = _ARRAY_OF[INT8]


class Float8s(Array):
    oid = _ARRAY_OF[FLOAT8]


class Texts(Array):
    oid = _ARRAY_OF[TEXT]


class _Dumper(adapt.Dumper):
    format = pq.Format.BINARY

    def dump(self, obj: object) -> bytes:
        assert isinstance(obj, Array)
        return bytes(obj)


_KINDS = (Int4s, Int8s, Float8s, Texts)
_DUMPERS = [
    (kind, type(f"{kind.__name__}Dumper", (_Dumper,), {"oid": kind.oid})) for kind in _KINDS
]


def register(context: psycopg.abc.AdaptContext) -> None:
    """Let ``context`` (a connection: it copies psycopg's global adapters when it is made)
    pass these arrays as they are."""
    for kind, dumper in _DUMPERS:
        context.adapters.register_dumper(kind, dumper)


#: Packers of ``n`` elements after the head, by element code and ``n`` (bounded).
_PACKS: dict[tuple[str, int], Callable[..., bytes]] = {}


def _packer(code: str, n: int) -> Callable[..., bytes]:
    got = _PACKS.get((code, n))
    if got is None:
        if len(_PACKS) >= 1024:
            _PACKS.clear()
        got = _PACKS[code, n] = struct.Struct("!iiIii" + ("i" + code) * n).pack
    return got


def _fixed(oid: int, code: str, size: int, items: Sequence[float | int]) -> bytes:
    """Elements of one fixed ``size`` (none NULL): each its length, then its value."""
    n = len(items)
    args: list[object] = [size] * (2 * n)
    args[1::2] = items
    return _packer(code, n)(1, 0, oid, n, 1, *args)


def int4s(items: Sequence[int]) -> Int4s:
    """An ``integer[]`` of ``items``."""
    return Int4s(_fixed(INT4, "i", 4, items))


def int8s(items: Sequence[int]) -> Int8s:
    """A ``bigint[]`` of ``items``."""
    return Int8s(_fixed(INT8, "q", 8, items))


def float8s(items: Sequence[float | None]) -> Float8s:
    """A ``double precision[]`` of ``items`` (``None``: NULL)."""
    if None not in items:
        return Float8s(_fixed(FLOAT8, "d", 8, items))  # type: ignore[arg-type]
    f8 = struct.Struct("!id").pack
    body = b"".join([NULL if v is None else f8(8, v) for v in items])
    return Float8s(_head(1, 1, FLOAT8, len(items), 1) + body)


def texts(items: Iterable[str | None]) -> Texts:
    """A ``text[]`` of ``items`` (``None``: NULL), each distinct text encoded once."""
    done: dict[str | None, bytes] = {None: NULL}
    parts: list[bytes] = []
    for t in items:
        got = done.get(t)
        if got is None:
            assert t is not None
            raw = clean(t)
            got = done[t] = _length(len(raw)) + raw
        parts.append(got)
    has_null = int(any(p is NULL for p in parts))
    return Texts(_head(1, has_null, TEXT, len(parts), 1) + b"".join(parts))
