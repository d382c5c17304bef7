"""One leaf of the parameter tree and the index placeholders of its patterns (§6.1)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sondalog.ala1.model import (
    Limits,
    View,
)
from sondalog.ala1.values import (
    Indices,
    ValueType,
)

Default = str | Callable[[View, Indices], str]
#: A computed read: the data lines of the answer (``read nothing`` answers none).
Reader = Callable[[View, Indices, str | None], list[str]]
#: A write with side effects: receives the parsed values (two for ``all``).
Writer = Callable[[View, Indices, list[str]], None]
#: A read of several targets at once: the data lines of the answer.
GroupReader = Callable[[View, list[Indices], str | None], list[str]]
#: A write that takes one value for all its targets (``write channel 1 3 value 5``).
GroupWriter = Callable[[View, list[Indices], list[str]], None]


@dataclass(frozen=True)
class IndexSpec:
    """An index that follows a keyword: ``device 3``, ``channel 1 3``, ``message``."""

    name: str
    hi: Callable[[Limits], int]
    optional: bool = False
    default: int = 1
    is_list: bool = False
    lo: int = 1
    doc: str = ""


INDEX_SPECS: dict[str, IndexSpec] = {
    "dev": IndexSpec("dev", lambda lim: lim.devices, doc="device 1..8"),
    "out": IndexSpec("out", lambda lim: lim.outputs, doc="output 1..7"),
    "cmd": IndexSpec("cmd", lambda lim: lim.commands, doc="command 1..4 (1.16) / 1..40 (2.10)"),
    "adr": IndexSpec("adr", lambda lim: lim.addresses, doc="address 1..8 / 1..40"),
    "msg": IndexSpec(
        "msg", lambda lim: lim.messages, optional=True, doc="message 1..2 / 1..40, default 1"
    ),
    "ch": IndexSpec(
        "ch",
        lambda lim: lim.channels,
        optional=True,
        is_list=True,
        doc="channel list, default all channels",
    ),
    "tab": IndexSpec("tab", lambda lim: 2, optional=True, doc="table 1 or 2, default 1"),
    "pt": IndexSpec("pt", lambda lim: 4, optional=True, doc="last-read point 1..4, default 1"),
    "n": IndexSpec(
        "n", lambda lim: 10_000_000, optional=True, lo=0, doc="at most n rows, default 1"
    ),
}


@dataclass(frozen=True)
class Leaf:
    """One parameter (or action) of the tree."""

    pattern: str
    vtype: ValueType
    access: str  # "R", "W" or "RW"
    default: Default
    section: str
    doc: str
    dual: bool = False  # two inputs with ``all`` (§6.5.12.2)
    hexable: bool = False  # ``x`` reads/writes hexadecimal (§6.5.5.2)
    aliases: tuple[str, ...] = ()
    reader: Reader | None = None
    writer: Writer | None = None
    read_arg: ValueType | None = None  # a read that takes a parameter (``read text/s/``)
    unavailable: str | None = None  # behaviour arrives with a later issue: error response
    ends_line: bool = False  # nothing may follow on the line (§7: ``write global reset``)
    stored: bool = True  # has a storage key
    default_doc: str = ""  # the factory value in words, when it depends on other values
    group_writer: GroupWriter | None = None  # one value for all targets
    group_reader: GroupReader | None = None  # all targets at once (speed, issue 11)
    #: The reader answers from the identity and the committed values only (issue 11).
    static: bool = False

    @property
    def constant_read(self) -> bool:
        """Reading it answers the same until a committed value changes: a stored value, or
        a :attr:`static` reader (issue 11)."""
        return self.reader is None or self.static

    @property
    def words(self) -> tuple[str, ...]:
        return tuple(self.pattern.split())

    def key(self, indices: Indices, slot: int = 1) -> str:
        """The storage key of one instance: the pattern with its indices filled in."""
        key = self.pattern.format(**indices)
        return key if slot == 1 else f"{key} #{slot}"

    def default_for(self, view: View, indices: Indices) -> str:
        return self.default(view, indices) if callable(self.default) else self.default
