"""What an HCTMPS1 module accepts as its settings (hctmps1.md §1, §4; Tabela 1), for the host.

The module core (:mod:`sondalog.hctmps1.module`) refuses a bad ``ADDP`` symbol, a bad
``NEWPW`` password and a ninth supervisor with ``<FA>``; the host checks a settings file by
the same rules before it writes anything (``sondalog bus config plan``). The two are kept in
agreement by ``tests/bus/test_bus_config_rules.py``. Module IDs are checked by
:func:`sondalog.protocol.hctmps1_frames.is_valid_id` (§2).
"""

from __future__ import annotations

#: Factory password (§1).
FACTORY_PASSWORD = "0000"
#: At most this many supervisors (``ADDSUP``, §1).
MAX_SUPERVISORS = 8
#: What ``HELLO`` answers, by variant name (Tabela 1, ``HELLO``).
HELLO_TEXTS: dict[str, str] = {
    "temp": "HCTMPS1-temp server (DS18B20)",
    "hum": "HCTMPS1-hum server (SHT11)",
}

_PASSWORD_CHARS = frozenset(chr(c) for c in range(0x21, 0x7F)) - {"|", ","}
_SYMBOL_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")


def is_valid_password(text: str) -> bool:
    """``NEWPW``: 1 to 16 printable characters without ``|``, ``,`` or space (§4)."""
    return 1 <= len(text) <= 16 and all(c in _PASSWORD_CHARS for c in text)


def is_valid_symbol(text: str) -> bool:
    """``ADDP``: 1 to 8 characters of ``A-Z a-z 0-9 _`` (§4)."""
    return 1 <= len(text) <= 8 and all(c in _SYMBOL_CHARS for c in text)


def variant_of(hello: str) -> str | None:
    """The variant name (``temp``, ``hum``) of a ``HELLO`` answer, None for another text."""
    return next((name for name, text in HELLO_TEXTS.items() if text == hello), None)
