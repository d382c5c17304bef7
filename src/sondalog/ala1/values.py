"""Value types of the parameter tree (§4.3, §6).

A value type parses a written value from a :class:`~sondalog.ala1.tokens.Cursor` into its
canonical stored text, and renders stored text for ``read``. Limits that differ between
protocol versions are looked up in the :class:`~sondalog.ala1.model.View`'s identity.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal

from sondalog.ala1.model import TOTAL_MEMORY, Limits, View
from sondalog.ala1.tokens import (
    NUMBER_LIMIT,
    Cursor,
    NumberFormat,
    ParseError,
    check_period,
    format_stamp,
    parse_stamp,
)

#: Indices that select one parameter instance: ``{"ch": 3, "tab": 1}``.
Indices = dict[str, int]


@dataclass(slots=True)
class ParseCtx:
    """What a value parser may need to know."""

    view: View
    indices: Indices
    multi: bool = False  # several instances in one command: dates/periods need all digits


class ValueType:
    """Base class: a value written after a leaf keyword."""

    kind = "value"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        raise NotImplementedError

    def render(self, stored: str, view: View, indices: Indices) -> str:
        return stored

    def check_stored(self, stored: str, view: View, indices: Indices) -> None:
        """Raise when a value loaded from the memory cannot be used (issue 9: a value that
        cannot be read back is repaired to its factory value at start)."""
        self.render(stored, view, indices)

    def describe(self, limits: Limits) -> str:
        """Human text of the limits for the generated reference (docs/protocol.md)."""
        return ""


@dataclass
class Text(ValueType):
    """An unknown-length string (§4.2.3) of at most ``max_len`` characters."""

    max_len: int | None = None
    kind = "string"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        value = cur.string()
        if self.max_len is not None and len(value) > self.max_len:
            cur.pos = start
            raise ParseError(f"string longer than {self.max_len} characters")
        return value

    def describe(self, limits: Limits) -> str:
        return f"at most {self.max_len} characters" if self.max_len else "any length"


@dataclass
class RestOfLine(ValueType):
    """The rest of the line, verbatim (§6.11.7: the value carries its own boundaries)."""

    kind = "rest of line"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        value = cur.rest()
        if not value.strip():
            raise ParseError("value expected")
        cur.pos = len(cur.text)
        return value

    def describe(self, limits: Limits) -> str:
        return "first character is the boundary of up to three parts; ends the line"


@dataclass
class Integer(ValueType):
    """An integer (§4.3.4) within ``lo..hi``; ``hi`` may depend on the protocol version."""

    lo: int = 0
    hi: int | Callable[[Limits], int] = 65535
    signed: bool = False
    kind = "integer"

    def high(self, limits: Limits) -> int:
        return self.hi(limits) if callable(self.hi) else self.hi

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        value = cur.integer(signed=self.signed or self.lo < 0)
        if not self.lo <= value <= self.high(ctx.view.identity.limits):
            cur.pos = start
            raise ParseError(f"{value} outside {self.lo}..{self.high(ctx.view.identity.limits)}")
        return str(value)

    def check_stored(self, stored: str, view: View, indices: Indices) -> None:
        if stored == "" and isinstance(self, OptionalInteger):
            return
        if not self.lo <= int(stored) <= self.high(view.identity.limits):
            raise ValueError(f"{stored} outside {self.lo}..{self.high(view.identity.limits)}")

    def describe(self, limits: Limits) -> str:
        return f"{self.lo}..{self.high(limits)}"


@dataclass
class OneOf(ValueType):
    """An integer from a fixed set (baud rates §6.11.2, timing §6.17.2)."""

    options: tuple[int, ...] = ()
    kind = "integer"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        value = cur.integer()
        if value not in self.options:
            cur.pos = start
            raise ParseError(f"{value} is not one of {self.options}")
        return str(value)

    def describe(self, limits: Limits) -> str:
        return ", ".join(str(o) for o in self.options)


@dataclass
class Choice(ValueType):
    """An enumerated keyword, any case on input, upper case on output (spec notes §1)."""

    options: tuple[str, ...] = ()
    #: options followed by an integer argument read back as ``NAME,N`` (§6.10.2.3)
    with_arg: dict[str, Integer] = field(default_factory=dict)
    kind = "keyword"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        cur.skip_spaces()
        words = [(o.lower(),) for o in self.options]
        chosen = cur.choose_keyword(words)
        if chosen is None:
            cur.pos = start
            raise ParseError(f"one of {', '.join(self.options)} expected")
        name = chosen[0].upper()
        arg = self.with_arg.get(name)
        if arg is not None:
            return f"{name},{arg.parse(cur, ctx)}"
        return name

    def describe(self, limits: Limits) -> str:
        names = [
            f"{o} n ({self.with_arg[o].describe(limits)})" if o in self.with_arg else o
            for o in self.options
        ]
        return " | ".join(names)


FormatRef = Callable[[View, Indices], NumberFormat]


def fixed(fmt: str) -> FormatRef:
    parsed = NumberFormat.parse(fmt)
    return lambda view, indices: parsed


@dataclass
class Number(ValueType):
    """A decimal number (§4.3.4) read back in a number format (§4.3.5)."""

    fmt: FormatRef = field(default_factory=lambda: fixed("0.6"))
    lo: Decimal | None = None
    hi: Decimal | None = None
    special: tuple[Decimal, ...] = ()  # values allowed outside lo..hi (record change -1)
    fmt_doc: str = "0.6"
    kind = "number"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        value = cur.number()
        if value not in self.special and (
            (self.lo is not None and value < self.lo)
            or (self.hi is not None and value > self.hi)
            or abs(value) >= NUMBER_LIMIT
        ):
            cur.pos = start
            raise ParseError(f"{value} out of range")
        return format(value, "f")  # plain digits, never an exponent form

    def render(self, stored: str, view: View, indices: Indices) -> str:
        return self.fmt(view, indices).render(Decimal(stored))

    def check_stored(self, stored: str, view: View, indices: Indices) -> None:
        value = Decimal(stored)
        if not value.is_finite() or abs(value) >= NUMBER_LIMIT:
            raise ValueError(f"{stored} is not a number below 10^15")
        self.render(stored, view, indices)

    def describe(self, limits: Limits) -> str:
        parts = []
        if self.lo is not None:
            parts.append(f">= {self.lo}")
        if self.hi is not None:
            parts.append(f"<= {self.hi}")
        parts.extend(f"or {s}" for s in self.special)
        if self.hi is None:
            parts.append("magnitude < 10^15")
        parts.append(f"read in format {self.fmt_doc}")
        return ", ".join(parts)


@dataclass
class Format(ValueType):
    """A number format ``w.p`` (§4.3.5)."""

    kind = "format"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return str(cur.number_format())

    def describe(self, limits: Limits) -> str:
        return "w.p, three characters"


@dataclass
class Date(ValueType):
    """A date ``YYYYMMDDhhmmss`` with fields missing on the left (§4.3.2)."""

    kind = "date"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return format_stamp(cur.date(ctx.view.now(), full=ctx.multi))

    def check_stored(self, stored: str, view: View, indices: Indices) -> None:
        parse_stamp(stored)

    def describe(self, limits: Limits) -> str:
        return "YYYYMMDDhhmmss; 2..12 digits fill from the clock"


@dataclass
class Period(ValueType):
    """A period ``hhmmss`` or ``99DDHH`` (§4.3.3); ``999901`` only when ``month``."""

    month: bool = False
    kind = "period"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return cur.period(full=ctx.multi, allow_month=self.month)

    def check_stored(self, stored: str, view: View, indices: Indices) -> None:
        check_period(stored, allow_month=self.month)

    def describe(self, limits: Limits) -> str:
        extra = ", 999901 = one month" if self.month else ""
        return f"hhmmss <= 96 h, 99DDHH <= 90 days{extra}"


@dataclass
class MemorySize(ValueType):
    """A memory area size: a multiple of 256 (§6.15)."""

    minimum: int = 0
    kind = "integer"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        value = cur.integer()
        if value % 256 or not self.minimum <= value <= TOTAL_MEMORY:
            cur.pos = start
            raise ParseError("a memory size is a multiple of 256 within the memory")
        return str(value)

    def describe(self, limits: Limits) -> str:
        return f"multiple of 256, {self.minimum}..{TOTAL_MEMORY}"


@dataclass
class ChannelAddress(ValueType):
    """A channel address (§6.5.5): integer; 64-bit in 2.10; hexadecimal after ``x``."""

    kind = "integer"

    def parse_hex(self, cur: Cursor, ctx: ParseCtx) -> str:
        return self._check(cur, cur.pos, cur.hex_integer(), ctx)

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return self._check(cur, cur.pos, cur.integer(), ctx)

    def _check(self, cur: Cursor, start: int, value: int, ctx: ParseCtx) -> str:
        if value > ctx.view.identity.limits.channel_address_max:
            cur.pos = start
            raise ParseError("channel address too large")
        return str(value)

    def describe(self, limits: Limits) -> str:
        return f"0..{limits.channel_address_max} (hexadecimal after x)"


@dataclass
class IntList(ValueType):
    """Comma-separated integers (§6.14.2.1: message addresses, up to 10 in 2.10)."""

    item: Integer = field(default_factory=Integer)
    max_count: Callable[[Limits], int] = lambda limits: 1
    kind = "integer list"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        items = [self.item.parse(cur, ctx)]
        while True:
            save = cur.pos
            cur.skip_spaces()
            if cur.pos < len(cur.text) and cur.text[cur.pos] == ",":
                cur.pos += 1
                items.append(self.item.parse(cur, ctx))
            else:
                cur.pos = save
                break
        if len(items) > self.max_count(ctx.view.identity.limits):
            cur.pos = start
            raise ParseError("too many items")
        return ",".join(items)

    def describe(self, limits: Limits) -> str:
        n = self.max_count(limits)
        return f"{self.item.describe(limits)}" + (
            f", up to {n} separated by commas" if n > 1 else ""
        )


@dataclass
class OutputValue(ValueType):
    """An output value (§6.7.3): ``0``, any other number = ``1``, or ``NO``."""

    kind = "0 | 1 | NO"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        cur.skip_spaces()
        if cur.try_keyword(("no",)):
            return "NO"
        try:
            value = cur.number()
        except ParseError:
            cur.pos = start
            raise
        return "0" if value == 0 else "1"

    def describe(self, limits: Limits) -> str:
        return "0, other number = 1, NO = released to automatic switching"


@dataclass
class NoValue(ValueType):
    """Actions that take no value (``write com close``)."""

    kind = "-"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return ""


@dataclass
class OptionalInteger(Integer):
    """An optional integer (the row type after ``write channel value``, §6.5.8)."""

    kind = "[integer]"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        return super().parse(cur, ctx) if cur.peek_digit() else ""

    def describe(self, limits: Limits) -> str:
        return f"optional {super().describe(limits)}"


@dataclass
class TextRow(ValueType):
    """``[t] /s/`` of ``write text`` (§6.19, spec notes §6): a digit 1-9 right after
    ``text`` (spaces allowed) is always the row type; then the string."""

    kind = "[type] string"

    def parse(self, cur: Cursor, ctx: ParseCtx) -> str:
        start = cur.pos
        row_type = "3"
        if cur.peek_digit():
            cur.skip_spaces()
            digit = cur.text[cur.pos]
            if digit == "0":
                raise ParseError("a row type is 1 to 9")
            row_type = digit
            cur.pos += 1
        try:
            text = cur.string()
        except ParseError:
            cur.pos = start
            raise
        return f"{row_type},{text}"

    def describe(self, limits: Limits) -> str:
        return "row type 1..9 (default 3), then a string"
