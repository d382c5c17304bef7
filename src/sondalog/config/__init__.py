"""Configuration: one typed reader for every file format of sondalog (docs/config-files.md).

- :mod:`.reader`: :class:`Table`, typed getters that know file, line and field;
- :mod:`.files`: reading a file safely (regular, size-limited, UTF-8, finite numbers) and
  finding a dotted field's line;
- :mod:`.address`: ``HOST:PORT`` and loopback, the one parser of listen addresses;
- :mod:`.errors`: :class:`ConfigError`, the one error type.

A leaf package: it imports nothing else of sondalog, so every layer may use it.
"""

from .address import format_address, is_loopback, parse_listen
from .errors import ConfigError
from .files import MAX_FILE_BYTES, locate, read_site_file, read_text, unknown
from .reader import REQUIRED, Source, Table, load, loads, of

__all__ = [
    "MAX_FILE_BYTES",
    "REQUIRED",
    "ConfigError",
    "Source",
    "Table",
    "format_address",
    "is_loopback",
    "load",
    "loads",
    "locate",
    "of",
    "parse_listen",
    "read_site_file",
    "read_text",
    "unknown",
]
