"""Generate ``docs/protocol.md`` from the parameter table (DESIGN.md point 3).

Run ``python -m sondalog.app.docgen > docs/protocol.md`` (``make docs``); a test keeps the
committed file in sync with the table.
"""

from __future__ import annotations

from sondalog.ala1.model import LIMITS, Identity, Version
from sondalog.ala1.params import INDEX_SPECS, LEAVES, Leaf
from sondalog.ala1.state import ModuleState
from sondalog.backends.store.ala1_nv import SqliteNvStore

_ACCESS = {"R": "read", "W": "write", "RW": "read/write"}


def _factory(leaf: Leaf, state: ModuleState) -> str:
    if leaf.default_doc:
        return leaf.default_doc
    if leaf.unavailable or (leaf.reader is None and not leaf.stored) or leaf.access == "W":
        return "-"
    view = state.begin(0.0)
    indices = {w[1:-1]: INDEX_SPECS[w[1:-1]].lo or 1 for w in leaf.words if w.startswith("{")}
    if leaf.reader is not None:
        lines = leaf.reader(view, indices, None)
        value = lines[0] if lines else ""
    else:
        value = leaf.vtype.render(view.get(leaf.key(indices)), view, indices)
    return f"`{value}`" if value else "(empty)"


def _limits(leaf: Leaf, version: Version) -> str:
    text = leaf.vtype.describe(LIMITS[version])
    if leaf.read_arg is not None:
        text = f"argument: {leaf.read_arg.kind}"
    return text or "-"


def _pattern(leaf: Leaf) -> str:
    words = [leaf.pattern, *leaf.aliases]
    text = " / ".join(f"`{w}`" for w in words)
    extras = []
    if leaf.dual:
        extras.append("`all` = both inputs `a,b`")
    if leaf.hexable:
        extras.append("`x` = hexadecimal")
    return text + (f" ({'; '.join(extras)})" if extras else "")


def render() -> str:
    state = ModuleState(Identity(Version.V2_10), SqliteNvStore(":memory:"), 0.0)
    out = [
        "# ALA1 protocol reference",
        "",
        "Generated from the parameter table `sondalog.ala1.params.LEAVES` by",
        "`make docs`; do not edit by hand (a test compares this file with the table).",
        "The manual (Czech, protocol 1.16 and 2.10) is the specification; see",
        "`docs/decisions.md` for the choices sondalog made where it is silent.",
        "",
        "## Indices",
        "",
        "| placeholder | meaning |",
        "|---|---|",
    ]
    out += [f"| `{{{name}}}` | {spec.doc} |" for name, spec in INDEX_SPECS.items()]
    out += [
        "",
        "## Parameters",
        "",
        "Factory values are those of a new 2.10 module (§11). Limits that differ between",
        "the versions are given for both.",
        "",
        "| keywords | access | type | factory value | limits 1.16 | limits 2.10 "
        "| section | meaning |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for leaf in LEAVES:
        access = _ACCESS[leaf.access]
        if leaf.unavailable:
            access += " (later issue)"
        old, new = _limits(leaf, Version.V1_16), _limits(leaf, Version.V2_10)
        row = [
            _pattern(leaf),
            access,
            leaf.vtype.kind,
            _factory(leaf, state),
            old,
            new if new != old else "same",
            leaf.section,
            leaf.doc,
        ]
        out.append("| " + " | ".join(cell.replace("|", "\\|") for cell in row) + " |")
    out += ["", f"Identity: `i device` is `{Identity().device}`.", ""]
    return "\n".join(out)


if __name__ == "__main__":
    print(render(), end="")
