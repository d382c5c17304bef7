"""The header of a command line (§8): keywords before the switch, each at most once."""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.ala1.model import BAUD_RATES
from sondalog.ala1.tokens import Cursor, ParseError

#: A command line is at most 120 characters (§3.4.1, §7).
MAX_LINE = 120

HEADER_WORDS = (
    "check",
    "crcsum",
    "sum",
    "pause",
    "comspeed",
    "quiet",
    "startline",
    "endline",
    "iname",
    "counter",
    "number",
    "date",
    "iaddress",
)
HEADER_OPTIONS = [(w,) for w in HEADER_WORDS]


@dataclass
class Headers:
    """The header keywords of one line (§8.2), each at most once."""

    seen: set[str] = field(default_factory=set)
    check: int | None = None
    check_from: int = 0
    check_text: str = ""
    crcsum: bool = False
    sum: bool = False
    pause: int | None = None
    comspeed: int | None = None
    quiet: bool = False
    startline: str = ""
    endline: str = ""
    iname: bool = False
    counter: int | None = None
    number: int | None = None
    date: bool = False
    iaddress: str | None = None

    def parse_one(self, word: str, cur: Cursor) -> None:
        """Parse the parameter of header keyword ``word`` (already consumed)."""
        if word in self.seen:
            raise ParseError(f"header {word} given twice")
        self.seen.add(word)
        if word == "check":
            self.check = cur.integer()
            self.check_from = cur.pos
            self.check_text = cur.text
        elif word == "pause":
            self.pause = cur.integer()
            if self.pause >= 3600:
                raise ParseError("pause must be below 3600 s (§8.5.1)")
        elif word == "comspeed":
            self.comspeed = cur.integer()
            if self.comspeed not in BAUD_RATES:
                raise ParseError("comspeed must be a §6.11.2 rate")
        elif word == "startline":
            self.startline = cur.string()
            if len(self.startline) > 20:
                raise ParseError("startline is at most 20 characters (§8.5.4)")
        elif word == "endline":
            self.endline = cur.string()
            if len(self.endline) > 10:
                raise ParseError("endline is at most 10 characters (§8.5.5)")
        elif word == "counter":
            self.counter = cur.integer()
            if not 1 <= self.counter <= 4:
                raise ParseError("counter is 1 to 4 (§8.5.7)")
        elif word == "number":
            self.number = cur.integer()
        elif word == "iaddress":
            self.iaddress = cur.string()
        else:
            setattr(self, word, True)
        if self.counter is not None and self.number is not None:
            raise ParseError("number and counter exclude each other")

    def check_ok(self) -> bool:
        """§8.3.1: the sum of the bytes after N to the end of the line equals N."""
        if self.check is None:
            return True
        tail = self.check_text[self.check_from :]
        return sum(tail.encode("latin-1")) == self.check
