"""Refusing unknown keys where the reader's line would mislead (a local stand-in).

:meth:`sondalog.config.Table.keys` names an unknown key at its ``key =`` line; an unknown
*array of tables* (``[[board.dht22]]``) has no such line, so the reader names the table that
holds it. :func:`known_keys` names it at its first ``[[...]]`` header instead. (Proposed for
:meth:`Table.keys` itself; until then the bus and board parsers use this.)
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable

from sondalog.config import ConfigError, Table, unknown


def known_keys(t: Table, known: Iterable[str]) -> Table:
    """:meth:`Table.keys`, naming an unknown ``[[array]]`` at its first header; ``t``."""
    allowed = set(known)
    for key in t:
        if key in allowed:
            continue
        error = t.fail(key, unknown(key, allowed))
        with contextlib.suppress(ConfigError):
            first = t.tables(key)[:1]
            if first:
                error = ConfigError(error.path, error.field, error.message, first[0].line())
        raise error
    return t
