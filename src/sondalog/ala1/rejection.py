"""Why the parser refused a line: the structured rejection (issue 25, item 4).

The module answers a refused line only with the error response (§3.3.1). The parser
(:mod:`sondalog.ala1.parser`) also says where and what, for a host tool to show: it raises
:class:`Refused`, a :class:`~sondalog.ala1.tokens.ParseError` carrying a :class:`Rejection`.
Both are built only when a line is refused; the interpreter catches them as any ParseError,
so the bytes of the answer do not change.
"""

from __future__ import annotations

from dataclasses import dataclass

from sondalog.ala1.tokens import ParseError
from sondalog.ala1.values import ValueType


@dataclass(frozen=True)
class Rejection:
    """The first token of a line the grammar does not take, and what it takes there."""

    position: int
    """0-based column of the rejected token (spaces before it skipped)."""
    token: str
    """The text found there, up to the next space; empty at the end of the line."""
    expected: tuple[str, ...]
    """Keywords, or value kinds (``string``, ``date``, ``1..12``), the grammar takes here."""
    section: str
    """The manual section of the rule broken (``§8.2``, ``§6.5``, ``§7``)."""
    reason: str
    """The parser's own complaint (``channel 13: this logger has channels 1..12``)."""
    what: str
    """Which part: ``header``, ``switch``, ``keyword``, ``index``, ``channels``, ``value``,
    ``chain`` (after a complete command, §7) or ``end`` (nothing may follow, §7)."""
    subject: str = ""
    """What was being parsed: the header keyword, or the parameter words read so far (for a
    ``value``: the parameter's pattern)."""
    vtype: ValueType | None = None
    """For a ``value``: the type the parameter takes."""


def rejection_at(
    text: str,
    pos: int,
    what: str,
    reason: str,
    section: str,
    expected: tuple[str, ...] = (),
    subject: str = "",
    vtype: ValueType | None = None,
) -> Refused:
    """:class:`Refused` for the token at or after ``pos`` in ``text``."""
    while pos < len(text) and text[pos] == " ":
        pos += 1
    token = text[pos:].split(" ", 1)[0]
    return Refused(Rejection(pos, token, expected, section, reason, what, subject, vtype))


class Refused(ParseError):
    """A ParseError that says where and what (:class:`Rejection`)."""

    def __init__(self, rejection: Rejection) -> None:
        super().__init__(rejection.reason)
        self.rejection = rejection
