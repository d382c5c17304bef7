"""The ALA1 parameter tree (§6.1, §11) declared once as data (DESIGN.md point 3).

Every leaf of the keyword tree is one :class:`Leaf`: its keyword pattern, value type, access,
factory value (§11), manual section and, where a parameter does more than store a value, the
behaviour that runs on read or write. Parsing, read/write, factory reset and the generated
reference (``docs/protocol.md``) all come from :data:`LEAVES`.

Patterns are keyword words with index placeholders:

``{dev}`` device 1..8, ``{out}`` output 1..7, ``{cmd}`` command, ``{adr}`` address,
``{msg}`` message (optional, default 1), ``{ch}`` channel list (optional, default all
channels 1..``channel max number``), ``{tab}`` table 1|2 (optional, default 1), ``{pt}`` last
read point 1..4 (optional, default 1), ``{n}`` number of record rows (optional, default 1).
"""

from sondalog.ala1.params.leaf import INDEX_SPECS, IndexSpec, Leaf
from sondalog.ala1.params.table import LEAVES, RESET_KEEPS
from sondalog.ala1.params.trie import ROOT, KeyInfo, Node, storage_keys
from sondalog.ala1.tokens import ParseError
from sondalog.ala1.values import fixed

__all__ = [
    "INDEX_SPECS",
    "LEAVES",
    "RESET_KEEPS",
    "ROOT",
    "IndexSpec",
    "KeyInfo",
    "Leaf",
    "Node",
    "ParseError",
    "fixed",
    "storage_keys",
]
