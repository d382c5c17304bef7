"""The ALA1 tokenizer (manual §4, spec notes §2).

A command line is scanned left to right by a :class:`Cursor`. Known-length tokens (keywords,
numbers, dates, periods, formats, channel lists) may touch each other or be separated by any
number of spaces; unknown-length strings carry their own boundary character (§4.2.3).
Every scanning method either consumes its token and returns it, or raises :class:`ParseError`
and leaves the cursor where it was.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from decimal import ROUND_HALF_UP, Context, Decimal


class ParseError(ValueError):
    """The line does not follow the grammar; the module answers with the error response."""


@dataclass(frozen=True, slots=True)
class NumberFormat:
    """A number format ``w.p`` (§4.3.5): minimum width and decimals."""

    width: int
    decimals: int

    def __str__(self) -> str:
        return f"{self.width}.{self.decimals}"

    @classmethod
    def parse(cls, text: str) -> NumberFormat:
        if len(text) != 3 or not text[0].isdigit() or text[1] != "." or not text[2].isdigit():
            raise ParseError(f"bad number format {text!r}")
        return cls(int(text[0]), int(text[2]))

    def render(self, value: Decimal | float | int) -> str:
        """Format ``value``: round half away from zero, pad left to the width (§4.3.5).

        Any finite value renders: the rounding context is as wide as the value needs, so no
        stored or computed number can make a read fail (issue 9). Writes are limited to
        :data:`NUMBER_LIMIT` and computed values beyond it read as no value, so in practice
        at most 15 integer digits appear."""
        dec = value if isinstance(value, Decimal) else Decimal(str(value))
        if not dec.is_finite():
            raise ParseError(f"{value} is not a number")
        quantum = Decimal(1).scaleb(-self.decimals)
        digits = max(dec.adjusted(), 0) + self.decimals + 2
        context = _WIDE if digits <= _WIDE.prec else Context(prec=digits)
        rounded = dec.quantize(quantum, rounding=ROUND_HALF_UP, context=context)
        if rounded == 0:
            rounded = abs(rounded)  # never print "-0.0"
        text = f"{rounded:.{self.decimals}f}"
        return text.rjust(self.width)


_DIGITS = frozenset("0123456789")
#: Written numbers must stay below this magnitude: 15 integer digits (sondalog decision,
#: docs/decisions.md "Number limits"), what a reading shows with room for 9 decimals.
NUMBER_LIMIT = Decimal(10) ** 15
_WIDE = Context(prec=40)


class Cursor:
    """A position in a command line (§4)."""

    __slots__ = ("_lower", "pos", "text")

    def __init__(self, text: str, pos: int = 0) -> None:
        self.text = text
        self.pos = pos
        self._lower: str | None = None

    def _lowered(self) -> str | None:
        """The line in lower case, once per cursor; None when lowering changes its length
        (a character such as U+0130 lowers to two): then keywords compare slice by slice."""
        lower = self._lower
        if lower is None:
            lower = self.text.lower()
            if len(lower) != len(self.text):
                return None
            self._lower = lower
        return lower

    # -- basics -----------------------------------------------------------------------------
    def skip_spaces(self) -> None:
        text, pos, end = self.text, self.pos, len(self.text)
        while pos < end and text[pos] == " ":
            pos += 1
        self.pos = pos

    def at_end(self) -> bool:
        """True when only spaces remain."""
        self.skip_spaces()
        return self.pos >= len(self.text)

    def rest(self) -> str:
        return self.text[self.pos :]

    def peek_digit(self) -> bool:
        """True when the next non-space character is a digit (spaces are not consumed)."""
        pos = self.pos
        while pos < len(self.text) and self.text[pos] == " ":
            pos += 1
        return pos < len(self.text) and self.text[pos] in _DIGITS

    # -- keywords ---------------------------------------------------------------------------
    def try_keyword(self, words: tuple[str, ...]) -> bool:
        """Consume the keyword words (any case, spaces optional before each word, §4.2.2)."""
        text, pos = self.text, self.pos
        lower = self._lowered()
        for word in words:
            while pos < len(text) and text[pos] == " ":
                pos += 1
            end = pos + len(word)
            if lower is not None:
                if not lower.startswith(word, pos):
                    return False
            elif text[pos:end].lower() != word:
                return False
            pos = end
        self.pos = pos
        return True

    def choose_word(self, words: Iterable[str]) -> str | None:
        """Consume the longest single keyword of ``words`` that matches here (any case,
        spaces before it optional), or return None: :meth:`choose_keyword` for one-word
        options, through an index by first letter built once per collection (the trie's
        word dictionaries live as long as the program)."""
        text, pos, end = self.text, self.pos, len(self.text)
        while pos < end and text[pos] == " ":
            pos += 1
        lower = self._lowered()
        if pos >= end or lower is None:
            found = self.choose_keyword([(w,) for w in words])
            return None if found is None else found[0]
        for word in _word_index(words).get(lower[pos], ()):
            if lower.startswith(word, pos):
                self.pos = pos + len(word)
                return word
        return None

    def choose_keyword(self, options: Sequence[tuple[str, ...]]) -> tuple[str, ...] | None:
        """Consume the longest of ``options`` that matches here, or return None."""
        best: tuple[str, ...] | None = None
        best_pos = -1
        start = self.pos
        for words in options:
            self.pos = start
            if self.try_keyword(words) and self.pos > best_pos:
                best, best_pos = words, self.pos
        self.pos = best_pos if best is not None else start
        return best

    # -- numbers ----------------------------------------------------------------------------
    def digits(self, *, max_len: int | None = None) -> str:
        """A run of digits after optional spaces (at most ``max_len``)."""
        self.skip_spaces()
        text, start = self.text, self.pos
        pos = start
        while (
            pos < len(text) and text[pos] in _DIGITS and (max_len is None or pos - start < max_len)
        ):
            pos += 1
        if pos == start:
            raise ParseError("digits expected")
        self.pos = pos
        return text[start:pos]

    def integer(self, *, signed: bool = False) -> int:
        """An integer (§4.3.4): optional minus (when ``signed``) and digits."""
        start = self.pos
        self.skip_spaces()
        negative = False
        if signed and self.pos < len(self.text) and self.text[self.pos] == "-":
            negative = True
            self.pos += 1
            if not (self.pos < len(self.text) and self.text[self.pos] in _DIGITS):
                self.pos = start
                raise ParseError("digits expected after '-'")
        try:
            value = int(self.digits())
        except ParseError:
            self.pos = start
            raise
        return -value if negative else value

    def number(self) -> Decimal:
        """A decimal number (§4.3.4): optional ``-``, digits, optional ``.`` and digits."""
        start = self.pos
        self.skip_spaces()
        text = self.text
        pos = self.pos
        if pos < len(text) and text[pos] == "-":
            pos += 1
        int_start = pos
        while pos < len(text) and text[pos] in _DIGITS:
            pos += 1
        if pos == int_start:
            self.pos = start
            raise ParseError("number expected")
        if pos + 1 < len(text) and text[pos] == "." and text[pos + 1] in _DIGITS:
            pos += 1
            while pos < len(text) and text[pos] in _DIGITS:
                pos += 1
        literal = text[self.pos : pos]
        self.pos = pos
        return Decimal(literal)

    def hex_integer(self) -> int:
        """A hexadecimal integer (§6.5.5.2), digits ``0-9 A-F`` in any case."""
        self.skip_spaces()
        text, start = self.text, self.pos
        pos = start
        while pos < len(text) and text[pos] in "0123456789abcdefABCDEF":
            pos += 1
        if pos == start:
            raise ParseError("hexadecimal number expected")
        self.pos = pos
        return int(text[start:pos], 16)

    def number_format(self) -> NumberFormat:
        """A number format, exactly three characters ``w.p`` (§4.3.5)."""
        self.skip_spaces()
        fmt = NumberFormat.parse(self.text[self.pos : self.pos + 3])
        self.pos += 3
        return fmt

    # -- strings ----------------------------------------------------------------------------
    def string(self) -> str:
        """An unknown-length string (§4.2.3, spec notes §2).

        The first character is the boundary; the string runs to the next boundary or the end
        of the line. A space boundary skips extra spaces and takes the next space-free word.
        """
        text, pos = self.text, self.pos
        if pos >= len(text):
            raise ParseError("string expected")
        boundary = text[pos]
        if boundary == " ":
            while pos < len(text) and text[pos] == " ":
                pos += 1
            if pos >= len(text):
                raise ParseError("string expected")
            end = text.find(" ", pos)
            end = len(text) if end < 0 else end
            self.pos = end
            return text[pos:end]
        end = text.find(boundary, pos + 1)
        if end < 0:
            self.pos = len(text)
            return text[pos + 1 :]
        self.pos = end + 1
        return text[pos + 1 : end]

    # -- dates and periods -------------------------------------------------------------------
    def _digit_groups(self, limit: int) -> str:
        """Up to ``limit`` digits; groups may be separated by spaces (§4.3.2, §4.3.3)."""
        start = self.pos
        collected = ""
        while len(collected) < limit and self.peek_digit():
            collected += self.digits(max_len=limit - len(collected))
        if not collected:
            self.pos = start
            raise ParseError("digits expected")
        return collected

    def date(self, now: datetime, *, full: bool = False) -> datetime:
        """A date ``YYYYMMDDhhmmss`` with missing fields on the left taken from ``now``."""
        start = self.pos
        digits = self._digit_groups(14)
        if len(digits) not in ((14,) if full else (2, 4, 6, 8, 10, 14)):
            self.pos = start
            raise ParseError(f"a date has 2 to 14 digits in whole fields, not {len(digits)}")
        filled = format_stamp(now)[: 14 - len(digits)] + digits
        try:
            return parse_stamp(filled)
        except ParseError:
            self.pos = start
            raise

    def period(self, *, full: bool = False, allow_month: bool = False) -> str:
        """A period ``hhmmss`` (§4.3.3); returns the canonical six digits."""
        start = self.pos
        digits = self._digit_groups(6)
        if len(digits) not in ((6,) if full else (2, 4, 6)):
            self.pos = start
            raise ParseError("a period has 2, 4 or 6 digits")
        digits = digits.ljust(6, "0")
        try:
            check_period(digits, allow_month=allow_month)
        except ParseError:
            self.pos = start
            raise
        return digits

    # -- channel lists ----------------------------------------------------------------------
    def channel_list(self) -> list[int] | None:
        """A channel list (§6.5.2): ``1 3 4`` or ``010304``; None when absent."""
        channels: list[int] = []
        while self.peek_digit():
            start = self.pos
            run = self.digits()
            if len(run) <= 2:
                channels.append(int(run))
            elif len(run) % 2 == 0:
                channels.extend(int(run[i : i + 2]) for i in range(0, len(run), 2))
            else:
                self.pos = start
                raise ParseError("a run of channel numbers must have an even length")
        return channels or None


#: Word collections seen by :meth:`Cursor.choose_word`, by identity: (the collection, its
#: words by first letter, longest first). The collection is held so its id stays unique.
_WORD_INDEXES: dict[int, tuple[object, dict[str, tuple[str, ...]]]] = {}


def _word_index(words: Iterable[str]) -> dict[str, tuple[str, ...]]:
    entry = _WORD_INDEXES.get(id(words))
    if entry is not None and entry[0] is words:
        return entry[1]
    by_first: dict[str, list[str]] = {}
    for word in sorted(words, key=len, reverse=True):
        if word:
            by_first.setdefault(word[0], []).append(word)
    index = {first: tuple(group) for first, group in by_first.items()}
    if len(_WORD_INDEXES) < 4096:  # the trie has a few hundred nodes; never grow unbounded
        _WORD_INDEXES[id(words)] = (words, index)
    return index


def parse_stamp(digits: str) -> datetime:
    """``YYYYMMDDhhmmss`` to a datetime; an impossible calendar date is a ParseError."""
    if len(digits) != 14 or not digits.isdigit():
        raise ParseError(f"bad date {digits!r}")
    try:
        return datetime(
            int(digits[0:4]),
            int(digits[4:6]),
            int(digits[6:8]),
            int(digits[8:10]),
            int(digits[10:12]),
            int(digits[12:14]),
        )
    except ValueError as exc:
        raise ParseError(f"impossible date {digits!r}") from exc


def format_stamp(moment: datetime) -> str:
    # %Y does not pad years below 1000 on every platform (glibc prints year 1 as "1")
    return f"{moment.year:04d}{moment:%m%d%H%M%S}"


MONTH_PERIOD = "999901"


def check_period(digits: str, *, allow_month: bool) -> None:
    """Validate a six-digit period (§4.3.3)."""
    hh, mm, ss = int(digits[0:2]), int(digits[2:4]), int(digits[4:6])
    if digits == MONTH_PERIOD:
        if not allow_month:
            raise ParseError("the one-month period is only for messages")
        return
    if hh == 99:
        if mm * 24 + ss > 90 * 24 or ss > 23:
            raise ParseError("a 99DDHH period is at most 90 days, hours below 24")
        return
    if mm > 59 or ss > 59 or hh * 3600 + mm * 60 + ss > 96 * 3600:
        raise ParseError("a period is at most 96 hours with minutes and seconds below 60")


def period_seconds(digits: str) -> int | None:
    """Length of a period in seconds; None for the one-month period (§4.3.3)."""
    if digits == MONTH_PERIOD:
        return None
    hh, mm, ss = int(digits[0:2]), int(digits[2:4]), int(digits[4:6])
    if hh == 99:
        return (mm * 24 + ss) * 3600
    return hh * 3600 + mm * 60 + ss
