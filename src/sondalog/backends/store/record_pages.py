"""The record on disk in pages (issue 23): :data:`PAGE_ROWS` rows a database row.

A logger's record is up to 40,000 rows (``ala1.md`` §6.6: a megabyte of memory). Kept a row
a database row, a restore that puts back a whole record (a cyclic record that wrapped since
the snapshot) deleted and inserted 40,000 rows of two b-trees, 80-300 ms of SQLite's own
work. Kept in pages it is a few hundred rows (docs/control.md "Figures"):

- ``record_page (logger, page, first, count, rows)``: the rows with sequence numbers
  ``first`` .. ``first + count - 1``, all in ``page`` (``seq // PAGE_ROWS``), as a JSON
  array (``rows``); a logger's pages follow each other without gaps;
- the ``meta`` row ``record_head`` is the sequence number of the oldest row in the record:
  rows below it are gone (a cyclic record dropped them, a ``clear`` erased them) even where
  a page still holds them. Whole pages below it are deleted with each commit; the page the
  head is in is left as it is (rewriting it with every sampled row would cost more than
  the few rows it keeps);
- a sampled row is appended to its page by SQLite itself (:func:`append_rows`: one
  ``UPDATE`` that joins the JSON arrays), so a commit writes about one database page;
- :func:`write_record` replaces a logger's record, writing only the pages that differ from
  the rows on disk now (a restore after a test: a dozen pages).

The view ``record (logger, seq, row)`` shows the rows in the record as the table of that
name did before (for readers: tests, ``sqlite3`` at a prompt); a file with that table is
converted when it is opened (:func:`migrate_rows`, inside the opening transaction).
"""

from __future__ import annotations

import json
import logging
import sqlite3
from collections.abc import Iterable, Sequence
from itertools import groupby

from sondalog.ala1.record import Sealed
from sondalog.ala1.record_page import PAGE, PageSource

log = logging.getLogger(__name__)

#: Rows a page holds: 64 sampled rows of a few channels fit in one 4 KiB database page (a
#: page in RAM is a page on disk: :data:`sondalog.ala1.record_page.PAGE`).
PAGE_ROWS = PAGE

TABLE = (
    "CREATE TABLE IF NOT EXISTS record_page (logger TEXT NOT NULL, page INTEGER NOT NULL, "
    "first INTEGER NOT NULL, count INTEGER NOT NULL, rows TEXT NOT NULL, "
    "PRIMARY KEY (logger, page))"
)
VIEW = (
    "CREATE VIEW IF NOT EXISTS record (logger, seq, row) AS "
    "SELECT p.logger, p.first + j.key, j.value FROM record_page AS p, json_each(p.rows) AS j "
    "WHERE p.first + j.key >= coalesce((SELECT CAST(m.value AS INTEGER) FROM meta AS m "
    "WHERE m.logger = p.logger AND m.key = 'record_head'), 0)"
)

_APPEND = (
    "UPDATE record_page SET rows = substr(rows, 1, length(rows) - 1) || ',' || substr(?, 2), "
    "count = count + ? WHERE logger = ? AND page = ? AND first + count = ?"
)
_PUT = (
    "INSERT OR REPLACE INTO record_page (logger, page, first, count, rows) VALUES (?, ?, ?, ?, ?)"
)
_UPSERT_HEAD = (
    "INSERT INTO meta (logger, key, value) VALUES (?, 'record_head', ?) "
    "ON CONFLICT(logger, key) DO UPDATE SET value = excluded.value"
)


#: The characters a row may hold to go into JSON as it is: printable ASCII but ``"`` and ``\\``.
_PLAIN = bytes(c for c in range(0x20, 0x7F) if c not in b'"\\')


def plain(rows: Sequence[str]) -> bool:
    """Whether every row is plain text (:data:`_PLAIN`), as a record's rows are: written
    into JSON as they are, ten times faster than :func:`json.dumps`."""
    text = "".join(rows)
    return text.isascii() and not text.encode("ascii").translate(None, _PLAIN)


def _json(rows: Sequence[str]) -> str:
    """``rows`` as a JSON array of ASCII."""
    if plain(rows):
        return '["' + '","'.join(rows) + '"]' if rows else "[]"
    return json.dumps(list(rows), ensure_ascii=True, separators=(",", ":"))


def _runs(rows: Iterable[tuple[int, str]]) -> Iterable[tuple[int, list[str]]]:
    """Rows (sequence number, row) cut into runs of consecutive numbers within one page:
    (the first's number, the rows)."""
    if isinstance(rows, list) and rows:  # (consecutive numbers, as a record hands them:
        seqs, texts = zip(*rows, strict=True)  # cut by slices at the pages' starts)
        first, end = seqs[0], seqs[0] + len(seqs)
        if seqs == tuple(range(first, end)):
            at = first
            while at < end:
                stop = min(end, (at // PAGE_ROWS + 1) * PAGE_ROWS)
                yield at, list(texts[at - first : stop - first])
                at = stop
            return
    first, run = 0, list[str]()
    for seq, row in rows:
        if run and (seq != first + len(run) or seq % PAGE_ROWS == 0):
            yield first, run
            run = []
        if not run:
            first = seq
        run.append(row)
    if run:
        yield first, run


def append_rows(conn: sqlite3.Connection, logger: str, rows: Iterable[tuple[int, str]]) -> None:
    """Rows (sequence number, row) the engine added, in the caller's transaction: each
    run goes onto the end of its page when the page ends just before it (one ``UPDATE``);
    otherwise the page is merged in Python (:func:`_merge`)."""
    for first, run in _runs(rows):
        page = first // PAGE_ROWS
        starts = first % PAGE_ROWS == 0  # (a page's first row follows no row of its page)
        appended = () if starts else (_json(run), len(run), logger, page, first)
        if starts or not conn.execute(_APPEND, appended).rowcount:
            _merge(conn, logger, page, first, run)


def _merge(conn: sqlite3.Connection, logger: str, page: int, first: int, run: list[str]) -> None:
    """A run that does not follow its page's rows: a new page; rows over some of the
    page's (they replace them, rows after them stay); or rows after a gap (the rows before
    the gap are below the record's head, a cyclic record dropped them: the page restarts)."""
    found = conn.execute(
        "SELECT first, rows FROM record_page WHERE logger = ? AND page = ?", (logger, page)
    ).fetchone()
    if found is not None:
        old_first, old = int(found[0]), json.loads(found[1])
        if old_first <= first <= old_first + len(old):
            at = first - old_first
            run = old[:at] + run + old[at + len(run) :]
            first = old_first
        elif first < old_first <= first + len(run):
            run = run + old[first + len(run) - old_first :]
    conn.execute(_PUT, (logger, page, first, len(run), _json(run)))


def drop_below(conn: sqlite3.Connection, logger: str, head: int) -> None:
    """The pages wholly below the record's head ``head`` go (the caller writes the head)."""
    conn.execute(
        "DELETE FROM record_page WHERE logger = ? AND page < ?", (logger, head // PAGE_ROWS)
    )


def load_rows(conn: sqlite3.Connection, logger: str, head: int | None) -> tuple[list[str], int]:
    """The rows in ``logger``'s record, oldest first, and the first one's sequence number
    (``head``: the ``record_head`` meta, None if never written)."""
    rows: list[str] = []
    start: int | None = None
    for first, text in conn.execute(
        "SELECT first, rows FROM record_page WHERE logger = ? ORDER BY page", (logger,)
    ):
        if start is not None and first != start + len(rows):
            log.warning(
                "record of %r: a gap before row %d, the rows before it dropped", logger, first
            )
            rows, start = [], None
        if start is None:
            start = int(first)
        rows += json.loads(text)
    if start is None:
        return [], head or 0
    if head is not None and head > start:
        del rows[: head - start]
        start = head
    return rows, start


def load_page(conn: sqlite3.Connection, logger: str, page: int) -> tuple[int, list[str]]:
    """The rows of ``page`` (first sequence number, rows; none: ``page``'s first, [])."""
    found = conn.execute(
        "SELECT first, rows FROM record_page WHERE logger = ? AND page = ?", (logger, page)
    ).fetchone()
    return (page * PAGE_ROWS, []) if found is None else (int(found[0]), json.loads(found[1]))


def load_pages(
    conn: sqlite3.Connection, logger: str, low: int, high: int
) -> list[tuple[int, int, list[str]]]:
    """Pages ``low`` to ``high`` that exist: (page, first sequence number, rows)."""
    found = conn.execute(
        "SELECT page, first, rows FROM record_page WHERE logger = ? AND page BETWEEN ? AND ?",
        (logger, low, high),
    )
    return [(int(page), int(first), json.loads(rows)) for page, first, rows in found]


#: A logger's newest page as :func:`newest_pages` read it: (page, first, rows as JSON).
NewestPage = tuple[int, int, str]


def stored_record(
    conn: sqlite3.Connection,
    logger: str,
    head: int,
    size: str,
    source: PageSource,
    read: tuple[NewestPage | None] | None = None,
) -> Sealed | None:
    """``logger``'s record as its newest page, its older pages in ``source``, if its size
    (``record_size``: ``HEAD,END,CHARS``, written with every commit) agrees with the pages
    on disk; None: the whole record must be read (:func:`load_rows`). ``read``: its newest
    page as :func:`newest_pages` read it (``(None,)``: it has none); None: read it here."""
    size_head, end, chars = map(int, size.split(","))
    found = newest(conn, logger, head, read)
    # (rows dropped before they reached the store: the disk ends before the head)
    if size_head != head or found is None or (found[0] != end and not found[0] < end == head):
        return None
    _, first, rows = found
    low, last = head // PAGE * PAGE, end // PAGE * PAGE  # the first page; the tail's start
    if end > last and first > max(last, head):
        return None  # (rows missing above the head)
    tail = [""] * (end - max(last, head))
    if end > last:  # rows of the unfinished page (those below the head stay "")
        kept = rows[max(last, head) - first :]
        tail[len(tail) - len(kept) :] = kept
    if head >= last:  # every row in the tail
        return Sealed((), tuple(tail), 0, source, chars)
    return Sealed((None,) * ((last - low) // PAGE), tuple(tail), head - low, source, chars)


def newest(
    conn: sqlite3.Connection,
    logger: str,
    head: int,
    read: tuple[NewestPage | None] | None = None,
) -> tuple[int, int, list[str]] | None:
    """Where ``logger``'s record ends without reading it (issue 24: a fleet starting): the
    sequence number after its newest row, and the rows of the newest page from its first
    (their first's number, the rows); None if a page is missing between the head's and the
    newest (the whole record is then read, :func:`load_rows`). ``read``: as
    :func:`stored_record`."""
    if read is None:
        found = conn.execute(
            "SELECT page, first, rows FROM record_page WHERE logger = ? ORDER BY page DESC LIMIT 1",
            (logger,),
        ).fetchone()
    else:
        (found,) = read
    if found is None:
        return head, head, []
    page, first, rows = int(found[0]), int(found[1]), json.loads(found[2])
    low = head // PAGE_ROWS
    if page > low:
        (count,) = conn.execute(
            "SELECT count(*) FROM record_page WHERE logger = ? AND page >= ?", (logger, low)
        ).fetchone()
        if count != page - low + 1 or first != page * PAGE_ROWS:
            return None
    return first + len(rows), first, rows


def newest_pages(conn: sqlite3.Connection) -> dict[str, NewestPage]:
    """Every logger's newest page in one query (a fleet starting, issue 24): each found
    through the primary key from the logger's ``record_head``, as :func:`newest` finds it."""
    return {
        str(logger): (int(page), int(first), str(rows))
        for logger, page, first, rows in conn.execute(
            "SELECT p.logger, p.page, p.first, p.rows FROM meta AS m JOIN record_page AS p "
            "ON p.logger = m.logger AND p.page = (SELECT max(page) FROM record_page AS q "
            "WHERE q.logger = m.logger) WHERE m.key = 'record_head'"
        )
    }


def write_record(
    conn: sqlite3.Connection,
    logger: str,
    first: int,
    rows: Sequence[str],
    now_first: int | None = None,
    now: Sequence[str] = (),
    made: MadePages | None = None,
) -> None:
    """In the caller's transaction, ``logger``'s record becomes ``rows`` from sequence
    number ``first`` (``record_head`` included). ``now`` (from ``now_first``): the rows in
    its record now, the same as on disk; the pages where they are the same as ``rows`` are
    left as they are. Without ``now_first`` every page is written. ``made``: what was made
    for these same ``rows`` before (the pages made here are added to it)."""
    conn.execute(_UPSERT_HEAD, (logger, str(first)))
    if not rows:
        conn.execute("DELETE FROM record_page WHERE logger = ?", (logger,))
        return
    last = first + len(rows) - 1
    low, high = first // PAGE_ROWS, last // PAGE_ROWS
    # two ranges of the primary key (one condition with OR would scan every row)
    conn.execute("DELETE FROM record_page WHERE logger = ? AND page < ?", (logger, low))
    conn.execute("DELETE FROM record_page WHERE logger = ? AND page > ?", (logger, high))
    made = MadePages() if made is None else made
    if now_first is not None and (now_first > last or now_first + len(now) <= first):
        # nothing in common (the record moved on past all of it): every page, as before
        if made.every is None or made.every[0][0] != logger:
            made.every = [_page(logger, page, first, rows, made) for page in range(low, high + 1)]
        conn.executemany(_PUT, made.every)
        return
    rows, now = list(rows), list(now)  # (slices compared: a tuple never equals a list)
    same = None if now_first is None else _same(first, rows, now_first, now)
    writes = []
    for page in _candidates(low, high, last, now_first, len(now), same):
        begin, end = max(first, page * PAGE_ROWS), min(last + 1, (page + 1) * PAGE_ROWS)
        if now_first is None or not _on_disk(page, begin, end, rows, first, now_first, now, same):
            writes.append(_page(logger, page, first, rows, made))
    conn.executemany(_PUT, writes)


class MadePages:
    """The JSON of a record's pages once made, by page, and the rows of a write of every
    page (a snapshot's: a test suite restores it again and again)."""

    __slots__ = ("every", "texts")

    def __init__(self) -> None:
        self.texts: dict[int, str] = {}
        self.every: list[tuple[str, int, int, int, str]] | None = None


def _page(
    logger: str, page: int, first: int, rows: Sequence[str], made: MadePages
) -> tuple[str, int, int, int, str]:
    """The ``record_page`` row of ``page`` of ``rows`` (from ``first``)."""
    begin = max(first, page * PAGE_ROWS)
    end = min(first + len(rows), (page + 1) * PAGE_ROWS)
    text = made.texts.get(page)
    if text is None:
        text = made.texts[page] = _json(rows[begin - first : end - first])
    return logger, page, begin, end - begin, text


def _candidates(
    low: int, high: int, last: int, now_first: int | None, now_rows: int, same: object
) -> Iterable[int]:
    """The pages ``low`` .. ``high`` that may differ on disk. Where the rows both records
    hold are the same (``same``), only the pages at either end: those that start before
    the rows on disk now, and those from where either record ends."""
    if now_first is None or same is None:
        return range(low, high + 1)
    before = range(low, min(high, (now_first - 1) // PAGE_ROWS) + 1)
    after = range(max(low, min(now_first + now_rows, last + 1) // PAGE_ROWS), high + 1)
    return sorted({*before, *after})


def _same(first: int, rows: list[str], now_first: int, now: list[str]) -> tuple[int, int] | None:
    """The sequence numbers ``(from, to)`` where ``rows`` and ``now`` both hold rows, if
    they are the same rows there (one comparison instead of one a page: a restore after a
    test, the record moved on by some rows)."""
    low, high = max(first, now_first), min(first + len(rows), now_first + len(now))
    if low < high and rows[low - first : high - first] == now[low - now_first : high - now_first]:
        return low, high
    return None


def _on_disk(
    page: int,
    begin: int,
    end: int,
    rows: list[str],
    first: int,
    now_first: int,
    now: list[str],
    same: tuple[int, int] | None,
) -> bool:
    """Whether ``page`` on disk holds rows ``begin`` .. ``end - 1`` of ``rows`` (from
    ``first``) as it is, the disk holding the record ``now`` (from ``now_first``): the same
    rows (``same``: all rows both hold are known to be), and none after ``end`` in the
    page. (Rows before ``begin`` may stay: ``begin`` is past the page's start only as the
    record's new head, the rows before it are gone.)"""
    now_end = now_first + len(now)
    if now_first > begin or min(now_end, (page + 1) * PAGE_ROWS) != end:
        return False
    # (rows begin .. end - 1 are both in ``now`` and the record: within ``same``'s span)
    return same is not None or (
        now[begin - now_first : end - now_first] == rows[begin - first : end - first]
    )


def migrate_rows(conn: sqlite3.Connection, table: str, logger: str | None = None) -> None:
    """The rows of a ``record`` table of before (``logger, seq, row``; ``seq, row`` of the
    one ``logger`` when given) into pages, in the caller's transaction."""
    if logger is None:
        source = conn.execute(f"SELECT logger, seq, row FROM {table} ORDER BY logger, seq")
    else:
        source = conn.execute(f"SELECT ?, seq, row FROM {table} ORDER BY seq", (logger,))
    for key, rows in groupby(source, key=lambda r: str(r[0])):
        for first, run in _runs((int(seq), str(row)) for _, seq, row in rows):
            _merge(conn, key, first // PAGE_ROWS, first, run)
