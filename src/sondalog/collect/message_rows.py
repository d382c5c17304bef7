"""A logger's data message -> record rows (§6.14, §6.8.4.1; pure, no I/O).

A message's body is the answer of its command exactly as a line would carry it, typically
``read record N from lastread shift``: record rows ending CR LF, perhaps a ``crcsum`` line
``CRC,LENGTH`` (§8.4.1), then ``OK``. Header keywords of the command decorate every line
(§8.5, spec notes §3 order): ``sum`` (``00713,``), ``startline``, ``iname`` (``i name,``),
``date`` (``YYYYMMDDhhmmss,``), ``number``/``counter`` (``n,``), then the line.

:func:`parse_message` finds each row by its record point (``YYYYMMDDhhmmss.c``, which no
decoration has) and parses it with the download's own row parser
(:func:`sondalog.client.records.parse_row`); the decoration before it is dropped, except the
``i name`` it may carry, which identifies the logger. A body with a line that is neither a row,
nor ``OK``, nor the crcsum line (or whose crcsum does not match) is :class:`MessageError`:
the collector skips the whole message, so a garbled message never stores half its rows.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from sondalog.client.records import Row, RowError, parse_row
from sondalog.protocol.cksum import cksum

_POINT = re.compile(r"\d{14}\.[0-9A-Z]")
_DIGITS = re.compile(r"\d+")
_CRC = re.compile(r"(\d+),(\d+)$")


class MessageError(ValueError):
    """A body that is not the answer of a record command."""


@dataclass(frozen=True, slots=True)
class MessageRows:
    """The rows of one message and the ``i name`` its lines carry (None without ``iname``)."""

    rows: tuple[Row, ...]
    name: str | None = None


def _split(line: str) -> tuple[list[str], str] | None:
    """``(decoration fields, row text)`` when ``line`` holds a record row, else None."""
    fields = line.split(",")
    for index, field in enumerate(fields):
        if _POINT.fullmatch(field):
            return fields[:index], ",".join(fields[index:])
    return None


def _name(decoration: list[str]) -> str | None:
    """The ``iname`` field of a decoration: the first field that is not a number."""
    for field in decoration:
        if field and not _DIGITS.fullmatch(field):
            return field
    return None


def parse_message(body: str) -> MessageRows:
    """The record rows of a message body; raises :class:`MessageError`."""
    lines = body.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    lines = [line for line in lines if line.strip()]
    rows: list[Row] = []
    names: set[str] = set()
    sent: list[str] = []  # the lines before a crcsum line, as sent (with CR LF)
    for number, line in enumerate(lines, start=1):
        split = _split(line)
        if split is not None:
            decoration, text = split
            try:
                rows.append(parse_row(text))
            except RowError as exc:
                raise MessageError(f"line {number}: {exc}") from None
            name = _name(decoration)
            if name is not None:
                names.add(name)
            sent.append(line)
            continue
        if line.rsplit(",", 1)[-1].strip() == "OK":
            continue
        crc = _CRC.search(line)
        if crc is not None:
            blob = "".join(s + "\r\n" for s in sent).encode("latin-1", "replace")
            if (int(crc.group(1)), int(crc.group(2))) != (cksum(blob), len(blob)):
                raise MessageError(f"line {number}: crcsum {crc.group(0)} does not match")
            sent.append(line)
            continue
        raise MessageError(f"line {number}: not a record row: {line[:80]!r}")
    if not rows:
        raise MessageError("no record rows")
    if len(names) > 1:
        raise MessageError(f"lines of several loggers: {', '.join(sorted(names))}")
    return MessageRows(tuple(rows), names.pop() if names else None)


def identify(
    message: MessageRows, sender: str, loggers: dict[str, str], default: str | None
) -> str | None:
    """The logger a message is from (docs/collector.md "Message sources"):

    1. the ``i name`` its lines carry (``iname`` header), mapped through ``loggers`` when it
       is a key there, else taken as the logger's id;
    2. else the sender (e-mail address or phone number) mapped through ``loggers``;
    3. else the source's ``logger``; None: unknown.
    """
    if message.name is not None:
        return loggers.get(message.name, message.name)
    if sender in loggers:
        return loggers[sender]
    return default
