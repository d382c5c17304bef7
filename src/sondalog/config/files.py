"""Configuration files (TOML): reading them safely, and finding a field's line.

One loader and one line locator serve every part of a site file (the logger, the bus, and
what later issues add) and every other TOML file of sondalog (collector, board files).
"""

from __future__ import annotations

import difflib
import math
import os
import re
import stat
import tomllib
from collections.abc import Iterable
from pathlib import Path

from .errors import ConfigError

#: The largest configuration file read (a site file of a 20,000-logger fleet is far smaller).
MAX_FILE_BYTES = 1 << 20


def read_text(path: Path, limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of the configuration file ``path``; raises :class:`ConfigError`.

    Only a regular file (after symlinks) of at most ``limit`` bytes is read: a FIFO, a
    device (``/dev/zero``) or a directory is refused before it is opened."""
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise ConfigError(path, "file", "not a regular file")
        if info.st_size > limit:
            raise ConfigError(path, "file", f"larger than {limit} bytes ({info.st_size})")
        with path.open("rb") as f:
            raw = f.read(limit + 1)
    except OSError as exc:
        raise ConfigError(path, "file", f"cannot read: {exc.strerror or exc}") from None
    if len(raw) > limit:
        raise ConfigError(path, "file", f"larger than {limit} bytes")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        bad = raw[exc.start : exc.start + 1].hex()
        message = f"not UTF-8 text (byte 0x{bad} at offset {exc.start}); save it as UTF-8"
        raise ConfigError(path, "file", message, line) from None


def read_site_file(path: Path) -> tuple[dict[str, object], str]:
    """The parsed TOML of a site file and its text (for line numbers in errors).

    Every configuration file of sondalog is read here (:func:`read_text`); a non-finite
    number (``inf``, ``nan``, ``1e309``) is refused at its field."""
    text = read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, "toml", str(exc)) from None
    found = _non_finite(data, "")
    if found is not None:
        where, value = found
        raise ConfigError(path, where, f"{value} is not a finite number", locate(text, where))
    return data, text


def _non_finite(value: object, where: str) -> tuple[str, float] | None:
    """The dotted field and value of the first ``inf`` or ``nan`` in ``value``."""
    if isinstance(value, float) and not math.isfinite(value):
        return where, value
    items: Iterable[tuple[str, object]] = ()
    if isinstance(value, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in value.items())
    elif isinstance(value, list):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(value))
    for field, item in items:
        if (found := _non_finite(item, field)) is not None:
            return found
    return None


def unknown(name: str, known: Iterable[str]) -> str:
    """``unknown table [name] (did you mean [x]? known: ...)`` for a misspelt name."""
    options = sorted(known)
    close = difflib.get_close_matches(name, options, n=1)
    hint = f"did you mean {close[0]}? " if close else ""
    return f"unknown table or key {name!r} ({hint}known: {', '.join(options)})"


#: One part of a dotted field: a bare or quoted key and an optional ``[index]``.
_PART = re.compile(r'(?:"((?:[^"\\]|\\.)*)"|([A-Za-z0-9_-]+))(?:\[(\d+)\])?')
_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\[\]#]+?)\s*\]\]?")


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
    parts = [
        (quoted if quoted else bare, index)
        for quoted, bare, index in _PART.findall(where)
        if quoted or bare
    ]
    lo, hi, found, prefix = 0, len(lines), None, ""
    for name, index in parts:
        full = f"{prefix}.{name}" if prefix else name
        matches = [
            n for n, array, h in headers if lo <= n < hi and h == full and array == bool(index)
        ]
        if not matches and not index:  # a whole array of tables ([[name]] headers)
            matches = [n for n, array, h in headers if lo <= n < hi and h == full and array]
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
            key = rf"(?:{re.escape(name)}|\"{re.escape(name)}\"|'{re.escape(name)}')"
            pattern = re.compile(rf"(^|[\s{{,]){key}\s*=")
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
