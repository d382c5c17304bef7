"""Why did the logger answer ``ERROR``? The host's explanation of a rejected command line.

The error response (§3.3.1) says only that a line was refused. :func:`explain` walks the
line with the logger's own tokenizer and parameter tree (:mod:`sondalog.ala1.tokens`,
:mod:`sondalog.ala1.params`, :mod:`sondalog.ala1.headers`, used read-only as a library),
the way the interpreter does (header §8.2, switch and body §5, chaining §7), and reports the
first token it rejects and what the grammar expected there::

    >>> print(explain("write channel 1 3 5 7 9 11 13 name /a/").render())  # doctest: +SKIP
    write channel 1 3 5 7 9 11 13 name /a/
                              ^^
    '13' (column 27): channel 13: this logger has channels 1..12

Also here: :data:`HELP`, the syntax in short for ``sondalog term``'s ``:help``, and
:func:`unsendable`, which names a character the logger's ASCII line cannot carry (§6.11).
"""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass

from sondalog.ala1.headers import HEADER_WORDS, Headers
from sondalog.ala1.model import Version
from sondalog.ala1.params import ROOT, IndexSpec, Leaf, Node
from sondalog.ala1.tokens import Cursor, ParseError
from sondalog.ala1.values import (
    Choice,
    Date,
    Format,
    Number,
    ParseCtx,
    Period,
    Text,
    TextRow,
    ValueType,
)
from sondalog.app.virtual import VirtualLogger
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


class _Rejected(Exception):
    def __init__(self, column: int, message: str) -> None:
        super().__init__(message)
        self.column = column
        self.message = message


def explain(line: str, version: str = "2.10") -> Explanation:
    """Walk ``line`` as a logger of protocol ``version`` would; see the module docstring."""
    text = edited(line)
    if len(line) > MAX_LINE and len(text) == MAX_LINE:
        return Explanation(
            text, MAX_LINE - 1, "a command line is at most 120 characters; the logger cut it"
        )
    logger = VirtualLogger(version=Version(version))
    try:
        view = logger.engine.state.begin(logger.clock.now())
        walk = _Walk(text, ParseCtx(view, {}))
        try:
            walk.run()
        finally:
            view.rollback()
    except _Rejected as exc:
        return Explanation(text, exc.column, exc.message)
    finally:
        logger.close()
    return Explanation(
        text,
        None,
        f"the local parser (protocol {version}) accepts this line. A logger may still refuse"
        " it: a value its state forbids (record type only while the record is empty, a"
        " read-only parameter, limits of protocol 1.16), a named command it does not have,"
        " or a feature it does not offer." + "".join(f"\nNote: {n}" for n in walk.notes),
    )


class _Walk:
    """One pass over a line; raises :class:`_Rejected` at the first bad token."""

    def __init__(self, text: str, ctx: ParseCtx) -> None:
        self.cur = Cursor(text)
        self.ctx = ctx
        self.limits = ctx.view.identity.limits
        self.string_boundary: str | None = None  # the boundary of the last string value
        #: Doubtful readings of a line that parses (a string boundary that is a letter).
        self.notes: list[str] = []

    def reject(self, column: int, message: str) -> _Rejected:
        return _Rejected(column, message)

    def run(self) -> None:
        cur = self.cur
        self._headers()
        switch = self._switch()
        assert switch is not None
        node, first = ROOT, None
        while True:
            leaf_first = self._command(switch, node, chained=first is not None)
            first = first or leaf_first
            if cur.at_end():
                return
            start = cur.pos
            new = self._switch(optional=True)
            if new is not None:
                switch, node, first = new, ROOT, None  # §7.1
            else:
                assert first is not None
                cur.pos = start
                node = ROOT.words[first]  # §7.2: the switch and first keyword carry over

    def _headers(self) -> None:
        cur, headers = self.cur, Headers()
        options = [(w,) for w in (*HEADER_WORDS, "read", "write")]
        while True:
            cur.skip_spaces()
            start = cur.pos
            word = cur.choose_keyword(options)
            if word is None:
                if cur.at_end():
                    raise self.reject(start, "read or write expected after the header keywords")
                raise self.reject(
                    start,
                    "expected read, write or a header keyword (check, sum, crcsum, quiet, pause,"
                    " ...); or the name of a command stored with `write command N name`"
                    " (§6.8): names are case-sensitive",
                )
            if word[0] in ("read", "write"):
                cur.pos = start
                return
            try:
                headers.parse_one(word[0], cur)
            except ParseError as exc:
                hint = _HEADER_HINTS.get(word[0], "")
                raise self.reject(cur.pos, f"{exc}; {hint}" if hint else str(exc)) from None

    def _switch(self, optional: bool = False) -> str | None:
        self.cur.skip_spaces()
        word = self.cur.choose_keyword([("read",), ("write",)])
        if word is None and not optional:
            raise self.reject(self.cur.pos, "read or write expected")
        return None if word is None else ("R" if word[0] == "read" else "W")

    def _command(self, switch: str, node: Node, *, chained: bool) -> str | None:
        """One command of the body; returns its first keyword (for §7.2 chaining)."""
        cur = self.cur
        first: str | None = None
        path: list[str] = []
        if node is not ROOT:
            path.append(next(w for w, n in ROOT.words.items() if n is node))
        while True:
            start = len(cur.text) - len(cur.rest().lstrip(" "))  # spaces stay: a string's
            word = cur.choose_keyword([(w,) for w in node.words])  # boundary may be one
            if word is not None:
                if node is ROOT:
                    first = word[0]
                path.append(word[0])
                node = node.words[word[0]]
                continue
            if node.index is not None:
                spec, child = node.index
                path.append(self._index(spec))
                node = child
                continue
            break
        leaf = node.leaves.get(switch)
        if leaf is None:
            raise self._no_leaf(node, switch, path, start, chained)
        while (leaf.dual and cur.try_keyword(("all",))) or (
            leaf.hexable and cur.try_keyword(("x",))
        ):
            pass
        vtype = leaf.read_arg if switch == "R" else leaf.vtype
        if vtype is not None:
            self._value(leaf, vtype)
        else:
            self.string_boundary = None
        if leaf.ends_line and not cur.at_end():
            raise self.reject(
                cur.pos, f"nothing may follow `write {leaf.pattern}` on its line (§7)"
            )
        return first

    def _index(self, spec: IndexSpec) -> str:
        cur = self.cur
        start = cur.pos
        high = spec.hi(self.limits)
        if spec.is_list:
            try:
                channels = cur.channel_list()
            except ParseError:
                raise self.reject(
                    start, "a channel list is `1 3 4` or `010304` (two digits per channel)"
                ) from None
            for ch in channels or []:
                if not 1 <= ch <= high:
                    raise self.reject(start, f"channel {ch}: this logger has channels 1..{high}")
            return " ".join(str(c) for c in channels or [])
        if not cur.peek_digit():
            if spec.optional:
                return ""
            raise self.reject(start, f"a number expected: {spec.doc}")
        value = cur.integer()
        if not spec.lo <= value <= high:
            raise self.reject(start, f"{value} is out of range: {spec.name} {spec.lo}..{high}")
        return str(value)

    def _no_leaf(
        self, node: Node, switch: str, path: list[str], start: int, chained: bool
    ) -> _Rejected:
        name = " ".join(p for p in path if p)
        other = "W" if switch == "R" else "R"
        verb = "read" if switch == "R" else "written"
        if other in node.leaves and self.cur.at_end():
            return self.reject(start, f"`{name}` cannot be {verb}")
        options = sorted(node.words)
        if node.index is not None:
            options.append(f"<{node.index[0].doc}>")
        if chained and not [p for p in path[1:] if p]:
            message = (
                "after a complete command the line ends, or goes on with read/write (§7.1) or"
                f" with another `{path[0]} ...` parameter (§7.2)"
            )
            if self.string_boundary is not None:
                message += f"; {_STRING_HINT}"
            return self.reject(start, message)
        if not options:
            return self.reject(start, f"`{name}` cannot be {verb}")
        what = f"after `{name}`" if name else "a parameter name"
        return self.reject(start, f"{what}: expected one of {', '.join(options)}")

    def _value(self, leaf: Leaf, vtype: ValueType) -> None:
        cur = self.cur
        start = cur.pos
        try:
            vtype.parse(cur, self.ctx)
        except ParseError as exc:
            error = str(exc)
            if isinstance(vtype, Date) and error.startswith("impossible date"):
                digits = "".join(cur.rest().lstrip(" ").split(" ")[0:1]).strip()
                fields = _DATE_FIELDS.get(len(digits), "")
                error = f"{len(digits)} digits are read as {fields}, which is no calendar date"
            raise self.reject(start, _expected(leaf, vtype, error, self.limits)) from None
        self.string_boundary = None
        if isinstance(vtype, Text | TextRow) and cur.pos > start:
            used = cur.text[start : cur.pos]
            if isinstance(vtype, TextRow):
                used = used.lstrip(" ")
                used = used[1:] if used[:1] in "123456789" else used
            boundary = used[:1]
            if boundary == " " or boundary.isalnum():
                self.string_boundary = boundary
                value = used.strip(" ") if boundary == " " else used[1:].removesuffix(boundary)
                self.notes.append(
                    f"the string at column {start + 1} took {boundary!r} as its boundary and"
                    f" reads {value!r}; {_STRING_HINT}"
                )


def _expected(leaf: Leaf, vtype: ValueType, error: str, limits: object) -> str:
    """What a value of ``vtype`` looks like, after the parser's own complaint."""
    if isinstance(vtype, Date):
        return (
            f"{error}. `{leaf.pattern}` fills from the left: the fields missing on the left come"
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
    described = vtype.describe(limits)  # type: ignore[arg-type]
    if isinstance(vtype, Choice):
        return f"{error}; `{leaf.pattern}` takes {described}"
    if isinstance(vtype, Number):
        return f"{error}; a number like `10`, `-0.8` or `13.8` ({described})"
    kind = vtype.kind
    return f"{error}; `{leaf.pattern}` takes {kind} {described}".rstrip()


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
