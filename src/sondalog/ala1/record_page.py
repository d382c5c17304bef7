"""A page of the record: :data:`PAGE` rows sealed into one compressed text (§6.6; issue 24).

:class:`Page` is how RAM holds a record's older rows (:mod:`sondalog.ala1.record`); a
:class:`PageSource` (the store) holds them durably, and :func:`loaded` reads a page back
from it, the last pages loaded kept decoded for every record of the process.
"""

from __future__ import annotations

import functools
import itertools
import zlib
from array import array
from collections import OrderedDict
from dataclasses import dataclass
from typing import Protocol

#: Rows sealed into one page (a page on disk holds as many: ``seq // PAGE``).
PAGE = 64
#: Raw deflate, level 1, a 4 KiB window: a page of 64 rows (about 5 KB) in 35 us instead
#: of 90 us (level 6, 32 KiB: most of that is setting up the window), at about 10 bytes a
#: row instead of 6; a simulated year seals some 8,000 pages.
_LEVEL, _WBITS = 1, -12


#: Pages loaded from the stores, kept decoded for all loggers (about 6 KB each).
LOADED_PAGES = 256
#: A read of more pages than this reads them in one go (:func:`read_pages`).
BULK = 8


class PageSource(Protocol):
    """Where a record's sealed pages are, durably (the store, issue 24)."""

    def load_page(self, page: int) -> tuple[int, list[str]]:
        """The rows stored in page ``page`` (sequence numbers ``page * PAGE`` ..): the first
        one's sequence number and the rows, all it has of them (none: an empty list)."""
        ...

    def load_pages(self, first: int, last: int) -> list[tuple[int, int, list[str]]]:
        """Pages ``first`` to ``last`` (those it has): (page, first sequence number, rows)."""
        ...


class PagedStore(Protocol):
    """A store that is a :class:`PageSource` for the records it loads (the engine then
    keeps only the newest rows in RAM)."""

    def load_paged_record(self) -> tuple[Sealed, int, bool, bool]:
        """As ``NvStore.load_record``; the pages may be ``None`` (in the source)."""
        ...


class RecordStore(Protocol):
    def load_record(self) -> tuple[list[str] | Sealed, int, bool, bool]: ...


class Page:
    """:data:`PAGE` rows in one compressed text, with where each row ends.

    A page made ``plain`` keeps its rows as they are (``data`` empty): a record whose pages
    the store holds lets go of a page once the store has its rows (``RecordMemory._evict``),
    so compressing it, and decompressing it to hand its rows to the store, was work for
    nothing (issue 24, sixth round). :func:`packed` makes a compressed page of one."""

    __slots__ = ("data", "ends", "rows")

    def __init__(self, rows: list[str], plain: bool = False) -> None:
        ends = list(itertools.accumulate(map(len, rows)))
        self.ends = array("H" if ends[-1] < 65536 else "I", ends)  # 2 bytes a row if they fit
        #: The rows of a plain page (None: they are in ``data``).
        self.rows: list[str] | None = rows if plain else None
        if plain:
            self.data = b""
        else:
            text = "".join(rows).encode("utf-8", "surrogatepass")
            self.data = zlib.compress(text, _LEVEL, wbits=_WBITS)

    def length(self, index: int) -> int:
        """The length of row ``index`` of the page (without decompressing it)."""
        return self.ends[index] - (self.ends[index - 1] if index else 0)


@dataclass(frozen=True, slots=True)
class Sealed:
    """A record's rows as RAM holds them (``RecordMemory.sealed``): the sealed pages
    (immutable, so shared), then the plain rows; the first ``head`` rows are not in the
    record. A snapshot keeps one, and a restore starts from it without sealing again.

    A store hands one with ``None`` pages (they are in ``source``) and the record's
    characters (``known_chars``): a start that reads only the newest page."""

    pages: tuple[Page | None, ...]
    tail: tuple[str, ...]
    head: int
    source: PageSource | None = None
    known_chars: int | None = None

    @property
    def chars(self) -> int:
        """The record's characters, each row with its CR LF."""
        if self.known_chars is not None:
            return self.known_chars
        assert all(page is not None for page in self.pages), "pages not in RAM: known_chars"
        rows = len(self.pages) * PAGE + len(self.tail) - self.head
        whole, part = divmod(self.head, PAGE)  # the dropped rows: whole pages, then a part
        pages, kept = self.pages[whole:], self.tail
        if not pages:
            kept = self.tail[self.head - len(self.pages) * PAGE :]
        text = sum(page.ends[-1] for page in pages if page) + sum(map(len, kept))
        if pages and part and pages[0]:
            text -= pages[0].ends[part - 1]
        return text + 2 * rows


def packed(page: Page) -> Page:
    """``page`` compressed (itself if it is)."""
    return page if page.rows is None else Page(page.rows)


def decoded(page: Page) -> list[str]:
    """The rows of ``page`` (the pages read last are kept decoded, for all modules)."""
    rows = page.rows
    return _decompressed(page) if rows is None else rows


@functools.lru_cache(maxsize=32)
def _decompressed(page: Page) -> list[str]:
    text = zlib.decompress(page.data, wbits=_WBITS).decode("utf-8", "surrogatepass")
    starts = itertools.chain((0,), page.ends)
    return [text[start:end] for start, end in zip(starts, page.ends, strict=False)]


#: (memory key, page on disk) -> the page's rows: pages loaded from a source, fleet-wide.
_LOADED: OrderedDict[tuple[object, int], list[str]] = OrderedDict()


def loaded(key: object, page: int, source: PageSource) -> list[str]:
    """The :data:`PAGE` rows of ``page`` of ``source`` (empty strings where it has none)."""
    found = _LOADED.get((key, page))
    if found is not None:
        _LOADED.move_to_end((key, page))
        return found
    found = _aligned(page, *source.load_page(page))
    _LOADED[key, page] = found
    if len(_LOADED) > LOADED_PAGES:
        _LOADED.popitem(last=False)
    return found


def read_pages(source: PageSource, first: int, last: int) -> dict[int, list[str]]:
    """Pages ``first`` to ``last`` of ``source`` as :func:`loaded` gives each, by page (a
    whole record read: one query, and the cache keeps what it held)."""
    return {page: _aligned(page, at, rows) for page, at, rows in source.load_pages(first, last)}


def _aligned(page: int, first: int, rows: list[str]) -> list[str]:
    """The :data:`PAGE` rows of ``page`` from its rows from ``first`` ("" where none)."""
    at = first - page * PAGE
    assert at >= 0 and at + len(rows) <= PAGE, f"page {page} holds rows of another"
    found = [""] * PAGE
    found[at : at + len(rows)] = rows
    return found
