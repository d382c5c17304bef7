"""A collector's contact in as few command lines as §7 allows, read at the bytes level (issue 24).

Every contact asks the same things: who answers and its clock (§6.2 ``i snumber``, ``date``),
the channels (§6.5.1 ``channel max number``, §6.5.6 ``type``, §6.5.7 ``format``, §6.5.3 the
names), how full the record is (§6.6.5 ``read record status``) and the first chunk of rows
after the cursor (§6.6.1.1, with the oldest row for the gap check). :func:`plan` chains them
with §7.2 (after the first keyword a command may go on without repeating it:
``read channel max number type format 1 name 2 name`` is five ``read channel`` commands,
``read record status 1 from start 20 from date/.../`` three ``read record`` ones) into lines of
at most :data:`MAX_LINE` characters (§7)::

    read i snumber read date read channel max number type format 1 name 2 name 3 name 4 name
    crcsum read record status 1 from start 20 from date/20070301120000.3/

Up to eight channels fit the first line; more go on lines of their own. Each line answers its
commands' data lines (every one of these answers exactly one, but the record's rows) and one
``OK`` (§7.1); the record line is verified with ``crcsum`` (§8.4.1) as a chunk always was.

:func:`parse` reads the pipelined answer of all the lines at once (one decode, one split, no
per-line objects): it says when the answer is complete, and hands back the answer lines, or
:class:`Unexpected` for anything else than this shape (a refused line, another count of lines,
a failed ``crcsum``). The caller then goes step by step as before, so a logger that answers
otherwise (a 1.16 logger refuses nothing here, but a future one might) reads the same rows.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from sondalog.client.ala1_codec import MAX_LINE, ChecksumError, NoAnswer, verify_crc
from sondalog.client.download import Download, DownloadError, LoggerInfo
from sondalog.client.records import Channel, split_name, stamp

#: The identification (§6.2, §6.5.1, §6.5.6, §6.5.7): five commands, one data line each.
IDENT = "read i snumber read date read channel max number type format"
#: The data lines :data:`IDENT` answers.
IDENT_LINES = 5


class Unexpected(Exception):
    """The answer does not have the shape the lines ask for (refused, cut, mismatched)."""


@dataclass(frozen=True, slots=True)
class Plan:
    """The lines of one contact and the data lines each answers."""

    lines: tuple[str, ...]
    """The identification lines, then the record line (``crcsum`` included)."""
    answers: tuple[int, ...]
    """Data lines each identification line answers (the record line's count varies)."""
    names: int
    """Channel names asked (the channel count of the last contact)."""
    chunk: str
    """The record read of the record line, as :class:`~sondalog.client.download.Download`
    would send it alone (its prefetched chunk)."""
    payload: bytes
    """Every line with its CR, as written to the line."""


@dataclass(frozen=True, slots=True)
class Answer:
    """The parsed answer of a :class:`Plan`."""

    ident: tuple[str, ...]
    """i snumber, date, channel max number, channel type, channel format, then the names."""
    status: str
    """The answer of ``read record status``."""
    rows: tuple[str, ...]
    """The lines of the record read (the oldest row first when reading after a cursor)."""
    chunk: bytes
    """The bytes of the record read's answer (its rows, ``crcsum`` line and ``OK``)."""
    crc: tuple[int, int]


def plan(names: int, chunk: str) -> Plan | None:
    """The lines that read the identification with ``names`` channel names, the record
    status and ``chunk`` (``read record ...``: one or two record reads); None when ``chunk``
    does not fit a line."""
    if not chunk.startswith("read record "):
        raise ValueError(f"not a record read: {chunk!r}")
    record = "crcsum read record status " + chunk.removeprefix("read record ").replace(
        " read record ", " "
    )
    if len(record) > MAX_LINE:
        return None
    lines, answers = _ident(names)
    text = (*lines, record)
    payload = ("\r".join(text) + "\r").encode("latin-1")
    return Plan(text, answers, names, chunk, payload)


_IDENT_CACHE: dict[int, tuple[tuple[str, ...], tuple[int, ...]]] = {}


def _ident(names: int) -> tuple[tuple[str, ...], tuple[int, ...]]:
    """The identification lines asking ``names`` names (§7.2: ``N name`` goes on after
    ``read channel``), and the data lines of each."""
    done = _IDENT_CACHE.get(names)
    if done is not None:
        return done
    lines, answers = [IDENT], [IDENT_LINES]
    for n in range(1, names + 1):
        piece = f" {n} name"
        if len(lines[-1]) + len(piece) > MAX_LINE:
            lines.append(f"read channel{piece}")
            answers.append(1)
        else:
            lines[-1] += piece
            answers[-1] += 1
    done = (tuple(lines), tuple(answers))
    _IDENT_CACHE[names] = done
    return done


def complete(raw: bytes | bytearray) -> bool:
    """Could ``raw`` be a whole answer (it ends with a final line)? Cheap: :func:`parse`
    decides."""
    return raw.endswith(b"OK\r\n") or raw.endswith(b"ERROR\r\n")


def parse(plan: Plan, raw: bytes) -> Answer | None:
    """The answer of ``plan``'s lines in ``raw`` (every byte received since they were
    written); None while it is not complete; :class:`Unexpected` for another shape.
    ``crcsum`` failures raise :class:`~sondalog.client.ala1_codec.CrcMismatch`."""
    if not complete(raw):
        return None
    text = raw.decode("latin-1")
    lines = text.split("\r\n")
    try:
        return _answer(plan, raw, text, lines)
    except Unexpected:
        # another shape: reported once every line has its final line (as a step by step
        # read would have taken them), so that nothing of it is left on the line
        if sum(1 for line in lines if line in ("OK", "ERROR")) < len(plan.lines):
            return None
        raise


def _answer(plan: Plan, raw: bytes, text: str, lines: list[str]) -> Answer | None:
    last = len(lines) - 1  # the "" after the final CR LF
    pos = 0
    ident: list[str] = []
    for command, count in zip(plan.lines, plan.answers, strict=False):
        _refused(lines, pos, last, command)
        end = pos + count
        if end >= last:
            return None
        if lines[end] != "OK":
            raise Unexpected(f"{command!r}: expected {count} lines and OK")
        ident += lines[pos:end]
        pos = end + 1
    record = plan.lines[-1]
    _refused(lines, pos, last, record)
    start = sum(map(len, lines[:pos])) + 2 * pos  # bytes before the record's
    try:
        end = lines.index("OK", pos, last)
    except ValueError:
        return None
    if end != last - 1:
        raise Unexpected(f"{end + 1} lines answered, {last} received")
    if end - pos < 2:  # the status and the crcsum line at least
        raise Unexpected(f"{record!r}: no record status or crcsum line")
    crc_at = len(text) - len(lines[end]) - len(lines[end - 1]) - 4
    crc = verify_crc(lines[end - 1], raw[start:crc_at])
    status_end = start + len(lines[pos]) + 2
    return Answer(tuple(ident), lines[pos], tuple(lines[pos + 1 : end - 1]), raw[status_end:], crc)


def _refused(lines: Sequence[str], pos: int, last: int, command: str) -> None:
    """:class:`Unexpected` when the answer at ``pos`` is the error response to ``command``
    (the line echoed, then ``ERROR``, §3.3.1)."""
    if pos + 1 < last and lines[pos + 1] == "ERROR" and lines[pos] == command:
        raise Unexpected(f"the logger refused {command!r}")


#: What a contact reads beside the identification when it goes step by step
#: (:meth:`Download.contact`'s ``extra``): the record status, both channel lists in one line.
STEPWISE = ("read record status", "read channel type read channel format")


@dataclass(frozen=True, slots=True)
class Visit:
    """What :func:`visit` reads beside the first chunk (which the download holds)."""

    info: LoggerInfo
    status: str | None
    """The answer of ``read record status`` (§6.6.5); None when refused."""
    kinds: tuple[str, ...]
    """The answers of ``read channel type`` and ``read channel format`` (§6.5.6, §6.5.7);
    () when refused."""
    key: tuple[str, ...] | None = None
    """The identification but the clock, as answered (None: read step by step). The same
    key at the next contact is the same serial number, channel count, types, formats and
    names."""


#: What a source keeps of its last contact for :func:`visit`: the identification's key and
#: the channels it named.
Known = tuple[tuple[str, ...], dict[int, Channel]]


def keep(visited: Visit) -> Known | None:
    """What to keep of ``visited`` for the next contact (its strings shared with the other
    sources' where they are the same: names, types, formats), or None."""
    if visited.key is None:
        return None
    return tuple(sys.intern(text) for text in visited.key), visited.info.channels


async def visit(download: Download, channels: int | None, last: Known | None = None) -> Visit:
    """A collector's contact over ``download``'s line: the identification, the record status,
    the channel types and formats and the download's first chunk in the lines of
    :func:`plan` (for up to eight channels two lines, one answer each, one write), with
    ``channels`` (the channel count of the last contact) names. ``last`` is what was kept of
    the last contact (:func:`keep`): when the identification answers the same
    (:attr:`Visit.key`), its channels are taken as they are, not parsed again.

    Any other shape (a refused or cut line, a failed ``crcsum``, a cursor too long for a
    line) goes the way of :meth:`Download.contact`, which reads the same things step by step
    on the same line; no answer at all is the logger's silence, raised as
    :class:`~sondalog.client.ala1_codec.NoAnswer`."""
    guess = channels if channels is not None and 1 <= channels <= 99 else 0
    lines = plan(guess, download.first)
    answer, raw = None, b"?"
    before = download.clock()
    if lines is not None:
        try:
            answer, raw = await download.client.exchange(
                lines.payload, functools.partial(parse, lines)
            )
        except (Unexpected, ChecksumError):
            answer = None
    after = download.clock()
    if lines is None or answer is None:
        if not raw:
            raise NoAnswer(f"no answer to {lines.lines[0] if lines else download.first!r}")
        info, (status, kinds) = await download.contact(STEPWISE, channels)
        text = status.lines[0] if status.ok and status.lines else None
        return Visit(info, text, kinds.lines if kinds.ok else ())
    ident = answer.ident
    try:
        logger_time = stamp(ident[1])
        count = int(ident[2])
    except ValueError as exc:
        raise DownloadError(f"the logger answers garbage: {exc}") from None
    if not 1 <= count <= 99:
        raise DownloadError(f"the logger answers garbage: {count} channels")
    names = ident[IDENT_LINES : IDENT_LINES + count]
    if count > guess:  # more channels than at the last contact: their names too
        names += tuple(await download.names(guess + 1, count))
    key = (ident[0], *ident[2:IDENT_LINES], *names)
    if last is not None and key == last[0]:
        named = last[1]
    else:
        named = {n: split_name(name) for n, name in enumerate(names, start=1)}
    elapsed = max(after - before, 1e-6) * len(answer.chunk) / max(len(raw), 1)
    download.prefetched(answer.rows, answer.chunk, answer.crc, elapsed)
    info = download.identified(ident[0], named, logger_time, (before, after))
    return Visit(info, answer.status, ident[3:IDENT_LINES], key)
