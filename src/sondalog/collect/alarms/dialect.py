"""What differs in the alarm store's SQL between SQLite and PostgreSQL (issue 21).

The store's statements are written once (:mod:`.store_sql`), in the SQL both servers
understand (``INSERT ... ON CONFLICT ... DO NOTHING``/``DO UPDATE``, ``UPDATE ...
RETURNING``, ``CASE`` rather than ``max``/``greatest``), with ``?`` for each parameter and
two place holders for row locks. A :class:`Dialect` turns such a text into its server's:

- ``?`` becomes the driver's marker (``sqlite3``: ``?``; psycopg: ``%s``);
- ``{lock}`` ends a ``SELECT`` of rows about to be changed: nothing on SQLite (the
  ``BEGIN IMMEDIATE`` transaction holds the whole file), ``FOR UPDATE`` on PostgreSQL;
- ``{skip_locked}`` ends the claim's ``SELECT``: nothing on SQLite, ``FOR UPDATE SKIP
  LOCKED`` on PostgreSQL (two collectors never take the same outbox row).

The tables' types differ too (``REAL``/``DOUBLE PRECISION`` ...): :mod:`.schema` has both
texts. Opening, transactions and lost connections are the stores' own
(:mod:`.store`, :mod:`.store_pg`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Dialect:
    """One server's spelling of the store's SQL."""

    name: str
    #: The driver's parameter marker.
    mark: str
    #: After a ``SELECT`` of rows the transaction changes next.
    lock: str
    #: After the claim's ``SELECT`` of due outbox rows.
    skip_locked: str

    def sql(self, text: str) -> str:
        """``text`` (``?`` markers, ``{lock}``, ``{skip_locked}``) in this dialect."""
        return _adapt(self, text)


@functools.cache
def _adapt(dialect: Dialect, text: str) -> str:
    if "%" in text and dialect.mark == "%s":  # a literal % would be a psycopg marker
        raise ValueError(f"a literal % in SQL for {dialect.name}: {text!r}")
    done = text.format(lock=dialect.lock, skip_locked=dialect.skip_locked)
    return done.replace("?", dialect.mark)


SQLITE = Dialect("sqlite", mark="?", lock="", skip_locked="")
POSTGRES = Dialect(
    "postgresql", mark="%s", lock=" FOR UPDATE", skip_locked=" FOR UPDATE SKIP LOCKED"
)
