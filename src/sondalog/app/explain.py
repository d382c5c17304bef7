"""Why did the logger answer ``ERROR``? The host's explanation of a rejected command line.

The error response (§3.3.1) says only that a line was refused. :func:`explain` runs the
logger's own parser (:func:`sondalog.ala1.parser.parse_line`) over the factory parameters
and renders the :class:`~sondalog.ala1.rejection.Rejection` it returns: the first token the
grammar refuses (header §8.2, switch and body §5, chaining §7) and what it takes there::

    >>> print(explain("write channel 1 3 5 7 9 11 13 name /a/").render())  # doctest: +SKIP
    write channel 1 3 5 7 9 11 13 name /a/
                              ^^
    '13' (column 27): channel 13: this logger has channels 1..12

Also here: :data:`HELP`, the syntax in short for ``sondalog term``'s ``:help``, and
:func:`unsendable`, which names a character the logger's ASCII line cannot carry (§6.11).
"""

from __future__ import annotations

import functools
import time
import unicodedata
from dataclasses import dataclass

from sondalog.ala1.headers import HEADER_WORDS, Headers
from sondalog.ala1.model import Identity, Limits, Version
from sondalog.ala1.parser import Command, Parsed, parse_line
from sondalog.ala1.rejection import Rejection
from sondalog.ala1.state import ModuleState
from sondalog.ala1.tokens import Cursor, ParseError
from sondalog.ala1.values import (
    Choice,
    Date,
    Format,
    Number,
    Period,
    Text,
    TextRow,
    ValueType,
)
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.client.ala1_codec import MAX_LINE, edited

_HEADER_HINTS = {
    "check": "check N: N is the sum of the byte values after N (`check 890 read date`, §8.3.1)",
    "pause": "pause N: seconds below 3600 (`pause 10 read channel value`, §8.5.1)",
    "comspeed": "comspeed N: a rate of §6.11.2 (`comspeed 1200 read record 10 from start`)",
    "startline": "startline needs a string with a boundary, at most 20 characters: `startline/>/`",
    "endline": "endline needs a string with a boundary, at most 10 characters: `endline/;/`",
    "counter": "counter K: K is 1 to 4, and not together with number (§8.5.7)",
    "number": "number N: lines are numbered from N, and not together with counter (§8.5.6)",
    "iaddress": "iaddress needs a string with a boundary: `iaddress/A1/ read date` (§8.6.1)",
}
_DATE_FIELDS = {
    2: "ss",
    4: "mmss",
    6: "hhmmss",
    8: "DDhhmmss",
    10: "MMDDhhmmss",
    14: "YYYYMMDDhhmmss",
}
_STRING_HINT = (
    "a string needs a boundary, the character right after its keyword: `read text/hi there/`"
    " (not `read text /hi there/`: after a space the string is the next word)"
)


@dataclass(frozen=True)
class Explanation:
    """Where the local parser rejected a line, and what it expected there."""

    line: str
    """The line as the logger keeps it (``+`` dropped, BS/DEL applied, §3.4)."""
    column: int | None
    """0-based position of the rejected token; None when the whole line parses."""
    message: str

    @property
    def accepted(self) -> bool:
        return self.column is None

    @property
    def token(self) -> str:
        """The rejected text up to the next space (empty at the end of the line)."""
        if self.column is None:
            return ""
        rest = self.line[self.column :].lstrip(" ")
        return rest.split(" ", 1)[0]

    def render(self) -> str:
        """The line, a caret under the rejected token, and the message."""
        if self.column is None:
            return f"{self.line}\n{self.message}"
        start = self.column + len(self.line[self.column :]) - len(self.line[self.column :].lstrip())
        token = self.token
        where = (
            f"{token!r} (column {start + 1})"
            if token
            else f"the end of the line (column {start + 1})"
        )
        marker = " " * start + "^" * max(1, len(token))
        return f"{self.line}\n{marker}\n{where}: {self.message}"


def explain(line: str, version: str = "2.10") -> Explanation:
    """Parse ``line`` as a logger of protocol ``version`` would; see the module docstring."""
    text = edited(line)
    if len(line) > MAX_LINE and len(text) == MAX_LINE:
        return Explanation(
            text, MAX_LINE - 1, "a command line is at most 120 characters; the logger cut it"
        )
    state = _default_state(version)
    view = state.begin(time.time())
    try:
        parsed = parse_line(text, view)
    finally:
        view.rollback()
    found = parsed.rejection
    if found is not None:
        return Explanation(text, found.position, _message(found, parsed, text, state))
    notes = [
        n for c, end in zip(parsed.commands, parsed.ends, strict=True) if (n := _note(c, end, text))
    ]
    return Explanation(
        text,
        None,
        f"the local parser (protocol {version}) accepts this line. A logger may still refuse"
        " it: a value its state forbids (record type only while the record is empty, a"
        " read-only parameter, limits of protocol 1.16), a named command it does not have,"
        " or a feature it does not offer." + "".join(f"\nNote: {n}" for n in notes),
    )


@functools.cache
def _default_state(version: str) -> ModuleState:
    """The factory parameters of a logger of ``version``: what the parser checks against."""
    return ModuleState(Identity(Version(version)), SqliteNvStore(":memory:"), 0.0)


def _message(found: Rejection, parsed: Parsed, text: str, state: ModuleState) -> str:
    """The parser's rejection in words, with the hint for its kind."""
    if found.what == "header" and not found.subject:
        return (
            "expected read, write or a header keyword (check, sum, crcsum, quiet, pause,"
            " ...); or the name of a command stored with `write command N name`"
            " (§6.8): names are case-sensitive"
        )
    if found.what == "header":
        hint = _HEADER_HINTS.get(found.subject, "")
        return f"{found.reason}; {hint}" if hint else found.reason
    if found.what == "value" and found.vtype is not None:
        reason = found.reason
        if isinstance(found.vtype, Date) and reason.startswith("impossible date"):
            digits = found.token
            fields = _DATE_FIELDS.get(len(digits), "")
            reason = f"{len(digits)} digits are read as {fields}, which is no calendar date"
        return _expected(found.subject, found.vtype, reason, state.identity.limits)
    if found.what == "chain" and parsed.commands:
        last = parsed.commands[-1]
        if _string_boundary(last, parsed.ends[-1], text) is not None:
            return f"{found.reason}; {_STRING_HINT}"
    return found.reason


def _string_used(command: Command, end: int, text: str) -> str | None:
    """The text of a command's string value (§4.2.3), or None when it takes none."""
    leaf = command.leaf
    vtype = leaf.read_arg if command.switch == "R" else leaf.vtype
    if not isinstance(vtype, Text | TextRow) or end <= command.at:
        return None
    used = text[command.at : end]
    if isinstance(vtype, TextRow):
        used = used.lstrip(" ")
        used = used[1:] if used[:1] in "123456789" else used
    return used


def _string_boundary(command: Command, end: int, text: str) -> str | None:
    """A doubtful boundary of a command's string value: a space or a letter or digit."""
    used = _string_used(command, end, text)
    boundary = (used or "")[:1]
    return boundary if boundary == " " or boundary.isalnum() else None


def _note(command: Command, end: int, text: str) -> str | None:
    boundary = _string_boundary(command, end, text)
    used = _string_used(command, end, text)
    if boundary is None or used is None:
        return None
    value = used.strip(" ") if boundary == " " else used[1:].removesuffix(boundary)
    return (
        f"the string at column {command.at + 1} took {boundary!r} as its boundary and"
        f" reads {value!r}; {_STRING_HINT}"
    )


def _expected(pattern: str, vtype: ValueType, error: str, limits: Limits) -> str:
    """What a value of ``vtype`` looks like, after the parser's own complaint."""
    if isinstance(vtype, Date):
        return (
            f"{error}. `{pattern}` fills from the left: the fields missing on the left come"
            " from the logger's clock, so 2, 4, 6, 8 or 10 digits are ss, mmss, hhmmss,"
            " DDhhmmss or MMDDhhmmss; give all 14 (YYYYMMDDhhmmss) to set the year (§4.3.2)"
        )
    if isinstance(vtype, Period):
        return (
            f"{error}. A period is hhmmss with missing fields on the right (`01` = one hour),"
            " at most 96 hours, or 99DDHH for days (at most 90; §4.3.3)"
        )
    if isinstance(vtype, Text | TextRow):
        return f"{error}; {_STRING_HINT}"
    if isinstance(vtype, Format):
        return f"{error}; a number format is three characters w.p, like `5.2` (§4.3.5)"
    described = vtype.describe(limits)
    if isinstance(vtype, Choice):
        return f"{error}; `{pattern}` takes {described}"
    if isinstance(vtype, Number):
        return f"{error}; a number like `10`, `-0.8` or `13.8` ({described})"
    kind = vtype.kind
    return f"{error}; `{pattern}` takes {kind} {described}".rstrip()


def header_words(line: str) -> frozenset[str]:
    """The header keywords (§8.2) that ``line`` starts with: ``{"quiet", "sum"}``."""
    cur, headers = Cursor(edited(line)), Headers()
    options = [(w,) for w in HEADER_WORDS]
    while (word := cur.choose_keyword(options)) is not None:
        try:
            headers.parse_one(word[0], cur)
        except ParseError:
            break
    return frozenset(headers.seen)


def unsendable(text: str) -> str | None:
    """Why ``text`` cannot go to the logger (its line is ASCII, §6.11), or None when it can.

    Names the first offending character, its position and a plain-ASCII suggestion.
    """
    for index, char in enumerate(text):
        if " " <= char <= "~" or char in "\x08\x7f":
            continue
        if char == "\t":
            return f"column {index + 1}: a TAB; the logger separates tokens with spaces"
        if ord(char) < 0x20:
            return (
                f"column {index + 1}: control character 0x{ord(char):02X} cannot be part of a"
                " command line (ESC discards the line, §3.4)"
            )
        name = unicodedata.name(char, f"U+{ord(char):04X}")
        plain = unicodedata.normalize("NFKD", char).encode("ascii", "ignore").decode()
        hint = f"; write {plain!r} instead" if plain.strip() else ""
        return (
            f"column {index + 1}: {char!r} ({name}) cannot be sent: the logger's line carries"
            f" ASCII only{hint}"
        )
    return None


HELP = """\
Local commands (not sent to the logger):
  :help            this text
  :log FILE        copy the session (lines sent as '> LINE', answers as received) to FILE;
                   ':log' alone stops
  :explain [LINE]  why the logger answered ERROR to LINE (default: the last refused line)
  :quit            leave (Ctrl-D also)

A command line (manual §5, §7, §8): [headers] read|write PARAMETER [VALUE] [more commands]
  read i version                       one parameter
  read channel 1 3 4 value             several channels: `1 3 4` or `010304`
  write channel 1 name/Air temp/       a string starts with its boundary, right after the
                                       keyword: name/Air temp/ or name*Air temp*
  write channel 1 sampling period 0010  sample every 10 minutes (hhmmss, filled on the right)
  write date 20260130120000            a date; fewer digits fill from the left: `1200` = mmss
  read record 10 from start            the oldest 10 rows of the record
  read record 5 from last read shift   rows since the last download, then move the mark
  read i device read date              several commands on one line, one OK at the end
  read channel 1 name 2 value          ... or the same first keyword continued (§7.2)
Header keywords, before read/write: check N, sum, crcsum, quiet, pause N, comspeed N,
  startline/s/, endline/s/, iname, counter K, number N, date, iaddress/s/
  sum read date                        every answer line carries a 5-digit byte sum
A leading + turns echo on for the line; ESC drops a half-typed line.
Keywords may be in any case; values (names, texts) are case-sensitive.
The full reference: docs/protocol.md; a walk-through: docs/tutorial.md.
"""
