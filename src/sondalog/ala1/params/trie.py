"""The keyword trie the parser walks, and the storage keys of a module (§4, §6.1)."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from sondalog.ala1.model import (
    Limits,
    Version,
)
from sondalog.ala1.params.leaf import INDEX_SPECS, IndexSpec, Leaf
from sondalog.ala1.params.table import LEAVES
from sondalog.ala1.values import (
    Indices,
)

# -- the keyword trie ------------------------------------------------------------------------


@dataclass
class Node:
    """A node of the keyword tree."""

    words: dict[str, Node] = field(default_factory=dict)
    index: tuple[IndexSpec, Node] | None = None
    leaves: dict[str, Leaf] = field(default_factory=dict)  # "R" / "W"


def _build() -> Node:
    root = Node()
    for leaf in LEAVES:
        for pattern in (leaf.pattern, *leaf.aliases):
            node = root
            for word in pattern.split():
                if word.startswith("{"):
                    spec = INDEX_SPECS[word[1:-1]]
                    if node.index is None:
                        node.index = (spec, Node())
                    node = node.index[1]
                else:
                    node = node.words.setdefault(word, Node())
            for access in leaf.access:
                if access in node.leaves:
                    raise RuntimeError(f"duplicate leaf {pattern} {access}")
                node.leaves[access] = leaf
    return root


ROOT: Node = _build()


@dataclass(frozen=True)
class KeyInfo:
    leaf: Leaf
    indices: Indices


def _expand(leaf: Leaf, limits: Limits) -> list[Indices]:
    names = [w[1:-1] for w in leaf.words if w.startswith("{")]
    combos: list[Indices] = [{}]
    for name in names:
        spec = INDEX_SPECS[name]
        combos = [{**c, name: i} for c in combos for i in range(spec.lo, spec.hi(limits) + 1)]
    return combos


@functools.cache
def storage_keys(version: Version) -> dict[str, KeyInfo]:
    """Every stored key of a module of ``version``, with its leaf and indices.

    Built once per version and shared by every module of it (read only: ~300 KiB, so a
    fleet of loggers holds one, issue 11)."""
    from sondalog.ala1.model import LIMITS

    limits = LIMITS[version]
    keys: dict[str, KeyInfo] = {}
    for leaf in LEAVES:
        if not leaf.stored:
            continue
        for indices in _expand(leaf, limits):
            info = KeyInfo(leaf, indices)
            keys[leaf.key(indices)] = info
            if leaf.dual:
                keys[leaf.key(indices, 2)] = info
    return keys
