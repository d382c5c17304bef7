"""Site files (TOML): reading them, and errors that name the file, line and field.

One loader and one line locator serve every part of a site file (the logger, the bus, and
what later issues add) and every other TOML file of sondalog (collector, board files).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path


class SiteError(ValueError):
    """A site file is wrong: ``path``, the dotted ``field`` and the ``line`` if known."""

    def __init__(self, path: Path | None, field: str, message: str, line: int | None = None):
        where = str(path) if path is not None else "<site>"
        if line is not None:
            where += f":{line}"
        super().__init__(f"{where}: {field}: {message}")
        self.path = path
        self.field = field
        self.line = line


#: ``fail(field, message)``: the :class:`SiteError` to raise for a field of the file.
Fail = Callable[[str, str], SiteError]


def serve_table(
    table: Mapping[str, object], where: str, keys: set[str], fail: Fail
) -> dict[str, object]:
    """``table``'s ``serve`` table (empty if absent), checked to hold only ``keys``."""
    serve = table.get("serve", {})
    if not isinstance(serve, Mapping):
        raise fail(f"{where}.serve", "must be a table")
    for key in serve:
        if key not in keys:
            raise fail(f"{where}.serve.{key}", f"unknown key (known: {', '.join(sorted(keys))})")
    return dict(serve)


def read_site_file(path: Path) -> tuple[dict[str, object], str]:
    """The parsed TOML of a site file and its text (for line numbers in errors)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SiteError(path, "file", f"cannot read: {exc.strerror or exc}") from exc
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise SiteError(path, "toml", str(exc)) from exc


_HEADER = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.\s\"]+?)\s*\]\]?")


def locate(text: str | None, where: str) -> int | None:
    """Best-effort line number of a dotted field (``bus.modules[2].signal.period``).

    Walks the field part by part: a ``[[array]]`` part narrows to its n-th element, a
    ``[table]`` part to that table (inside the current element), and the first part that has
    no header of its own is looked up as a ``key =`` line of the current table."""
    if text is None:
        return None
    lines = text.splitlines()
    headers = [
        (n, m.group(1) == "[[", m.group(2).replace(" ", "").replace('"', ""))
        for n, line in enumerate(lines)
        if (m := _HEADER.match(line))
    ]
    lo, hi, found, prefix = 0, len(lines), None, ""
    for name, index in re.findall(r"([A-Za-z0-9_]+)(?:\[(\d+)\])?", where):
        full = f"{prefix}.{name}" if prefix else name
        matches = [
            n for n, array, h in headers if lo <= n < hi and h == full and array == bool(index)
        ]
        pick = int(index) if index else 0
        if (
            not matches
            and not index
            and any(lo <= n < hi and h.startswith(full + ".") for n, _, h in headers)
        ):
            prefix = full  # only dotted sub-tables exist ([logger.gsm] without [logger])
            continue
        if pick >= len(matches):
            own_end = next((n for n, _, _ in headers if lo <= n < hi and n != found), hi)
            if found is not None:
                own_end = next((n for n, _, _ in headers if found < n < hi), hi)
            start = found + 1 if found is not None else lo
            pattern = re.compile(rf"(^|[\s{{,]){re.escape(name)}\s*=")
            for n in range(start, own_end):
                if pattern.search(lines[n]):
                    return n + 1
            return found + 1 if found is not None else None
        found = matches[pick]
        lo = found
        hi = next(
            (
                n
                for n, array, h in headers
                if n > found
                and ((h == full and array) or (h != full and not h.startswith(full + ".")))
            ),
            hi,
        )
        prefix = full
    return found + 1 if found is not None else None
