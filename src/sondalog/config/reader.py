"""The typed reader every configuration format of sondalog goes through.

A :class:`Table` is one TOML table (or JSON object) of a file, seen through typed getters
that know the file, the dotted field and (from the file's text) its line. Every getter
checks the value's type and range and raises :class:`ConfigError` --
``FILE:LINE: field: message`` -- on anything else; ``keys()`` refuses unknown keys and
tables with a "did you mean". Nothing outside this package checks a value's type by hand
(``tests/test_architecture.py``).

::

    root = load(path)                          # regular UTF-8 file, size-limited, finite
    web = root.table("web", keys={"listen", "token"})
    host, port = web.address("listen", default="127.0.0.1:8080")
    for source in root.tables("source", keys=SOURCE_KEYS):
        interval = source.number("interval", 60.0, above=0)
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Final, TypeVar

from .address import parse_listen
from .errors import ConfigError
from .files import locate, read_site_file, unknown

T = TypeVar("T")

#: A key, or a dotted path of keys (``logger.serve.listen``, ``loggers[1].listen``), written
#: as it is in a field; any other key is written quoted (``loggers."a@b.net"``).
_BARE = re.compile(r"[A-Za-z0-9_.\[\]-]+")


class _Missing:
    def __repr__(self) -> str:
        return "<required>"


#: The default of a required value.
REQUIRED: Final = _Missing()


@dataclass(frozen=True, slots=True)
class Source:
    """Where a configuration came from: its path and text (for line numbers)."""

    path: Path | None = None
    text: str | None = None
    #: The directory relative paths are relative to, if not the file's own.
    root: Path | None = None

    @property
    def base(self) -> Path | None:
        """The directory relative paths of the file are relative to."""
        if self.root is not None:
            return self.root
        return self.path.parent if self.path is not None else None

    def fail(self, field: str, message: str) -> ConfigError:
        return ConfigError(self.path, field, message, locate(self.text, field))


def load(path: Path) -> Table:
    """The root table of the TOML file ``path`` (:func:`files.read_site_file`: a regular
    UTF-8 file of bounded size with finite numbers only); raises :class:`ConfigError`."""
    data, text = read_site_file(path)
    return Table(Source(path, text), "", data)


def loads(text: str, path: Path | None = None) -> Table:
    """The root table of TOML ``text`` (as if read from ``path``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(path, "toml", str(exc)) from None
    return Table(Source(path, text), "", data)


def of(
    data: Mapping[str, object],
    path: Path | None = None,
    text: str | None = None,
    where: str = "",
    *,
    root: Path | None = None,
) -> Table:
    """A table over already parsed ``data`` (a JSON request body, a TOML document); relative
    paths in it are relative to ``root`` (default: ``path``'s directory)."""
    return Table(Source(path, text, root), where, data)


def _kind(value: object) -> str:
    match value:
        case bool():
            return "true/false"
        case int():
            return "an integer"
        case float():
            return "a number"
        case str():
            return "a string"
        case list():
            return "an array"
        case Mapping():
            return "a table"
    return type(value).__name__


class Table:
    """One table of a configuration: typed getters that name the file, line and field."""

    __slots__ = ("data", "source", "where")

    def __init__(self, source: Source, where: str, data: Mapping[str, object]) -> None:
        self.source = source
        self.where = where
        self.data = data

    # -- where and failing ---------------------------------------------------------------

    def field(self, key: str | None = None) -> str:
        """The dotted name of ``key`` (of the table itself without one)."""
        if key is None:
            return self.where
        name = key if _BARE.fullmatch(key) else json.dumps(key, ensure_ascii=False)
        return f"{self.where}.{name}" if self.where else name

    def fail(self, key: str | None, message: str) -> ConfigError:
        """The :class:`ConfigError` for ``key`` (the whole table without one)."""
        return self.source.fail(self.field(key), message)

    @property
    def file(self) -> Path | None:
        """The file the table is in (``None`` for data that came from no file)."""
        return self.source.path

    @property
    def base(self) -> Path | None:
        return self.source.base

    def line(self, key: str | None = None) -> int | None:
        return locate(self.source.text, self.field(key))

    # -- keys ----------------------------------------------------------------------------

    def keys(self, known: Iterable[str]) -> Table:
        """Refuse any key or table not in ``known`` (with a "did you mean"); ``self``."""
        allowed = set(known)
        for key in self.data:
            if key not in allowed:
                raise self.fail(key, unknown(key, allowed))
        return self

    def __contains__(self, key: object) -> bool:
        return key in self.data

    def __iter__(self) -> Iterator[str]:
        return iter(self.data)

    def __len__(self) -> int:
        return len(self.data)

    def raw(self, key: str, default: object = None) -> object:
        """The value of ``key`` as parsed, unchecked (for a value of several shapes)."""
        return self.data.get(key, default)

    def _given(self, key: str, default: object) -> bool:
        """Whether ``key`` is in the table; a missing required key fails here."""
        if key in self.data:
            return True
        if default is REQUIRED:
            raise self.fail(key, "required")
        return False

    # -- scalars -------------------------------------------------------------------------

    def text(
        self,
        key: str,
        default: str | _Missing = REQUIRED,
        *,
        choices: Iterable[str] | None = None,
        pattern: str | None = None,
        what: str | None = None,
        empty: bool = False,
    ) -> str:
        """A string; one of ``choices`` if given, matching ``pattern`` (whole) if given."""
        if not self._given(key, default):
            assert isinstance(default, str)
            return default
        value = self.data[key]
        if not isinstance(value, str):
            raise self.fail(key, f"must be {what or 'a string'}, not {_kind(value)}")
        if choices is not None:
            options = list(choices)
            if value not in options:
                raise self.fail(key, f"must be one of {', '.join(options)}, not {value!r}")
        if not value and not empty:
            raise self.fail(key, f"must be {what or 'a non-empty string'}")
        if pattern is not None and not re.fullmatch(pattern, value):
            raise self.fail(key, f"must be {what or f'a string like {pattern}'}, not {value!r}")
        return value

    def opt_text(
        self,
        key: str,
        *,
        choices: Iterable[str] | None = None,
        pattern: str | None = None,
        what: str | None = None,
    ) -> str | None:
        """:meth:`text` if ``key`` is given, else ``None``."""
        if key not in self.data:
            return None
        return self.text(key, choices=choices, pattern=pattern, what=what)

    def integer(
        self,
        key: str,
        default: int | _Missing = REQUIRED,
        *,
        lo: int | None = None,
        hi: int | None = None,
        what: str | None = None,
    ) -> int:
        """An integer (not true/false) in ``lo..hi``."""
        if not self._given(key, default):
            assert isinstance(default, int)
            return default
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, int) or not _within(value, lo, hi):
            raise self.fail(key, f"must be {what or _range('an integer', lo, hi)}, not {value!r}")
        return value

    def opt_integer(
        self, key: str, *, lo: int | None = None, hi: int | None = None, what: str | None = None
    ) -> int | None:
        return self.integer(key, lo=lo, hi=hi, what=what) if key in self.data else None

    def number(
        self,
        key: str,
        default: float | _Missing = REQUIRED,
        *,
        lo: float | None = None,
        hi: float | None = None,
        above: float | None = None,
        what: str | None = None,
    ) -> float:
        """A number (integer or float, not true/false): ``lo <= x <= hi``, ``x > above``.

        Non-finite numbers never get here (:func:`files.read_site_file` refuses them)."""
        if not self._given(key, default):
            assert isinstance(default, int | float)
            return float(default)
        value = self.data[key]
        ok = (
            not isinstance(value, bool)
            and isinstance(value, int | float)
            and value == value
            and _within(value, lo, hi)
            and (above is None or value > above)
        )
        if not ok:
            if what is None:
                what = _range("a number", lo, hi)
                if above is not None:
                    what = f"a number > {above:g}"
            raise self.fail(key, f"must be {what}, not {value!r}")
        assert isinstance(value, int | float)
        return float(value)

    def opt_number(
        self,
        key: str,
        *,
        lo: float | None = None,
        hi: float | None = None,
        above: float | None = None,
        what: str | None = None,
    ) -> float | None:
        if key not in self.data:
            return None
        return self.number(key, lo=lo, hi=hi, above=above, what=what)

    def flag(self, key: str, default: bool | _Missing = REQUIRED) -> bool:
        """true or false."""
        if not self._given(key, default):
            assert isinstance(default, bool)
            return default
        value = self.data[key]
        if not isinstance(value, bool):
            raise self.fail(key, f"must be true or false, not {value!r}")
        return value

    def address(
        self, key: str, default: str | _Missing = REQUIRED, *, what: str = "HOST:PORT"
    ) -> tuple[str, int]:
        """A ``"HOST:PORT"`` (``[IPv6]:PORT``) string -> ``(host, port)``."""
        value = self.data[key] if self._given(key, default) else default
        if not isinstance(value, str):
            raise self.fail(key, f'must be "{what}", not {_kind(value)}')
        try:
            return parse_listen(value)
        except ValueError as exc:
            raise self.fail(key, str(exc)) from None

    def path(self, key: str, default: str | Path | _Missing = REQUIRED) -> Path:
        """A path; a relative one is relative to the file's directory."""
        value = self.data[key] if self._given(key, default) else default
        if isinstance(value, Path):
            value = str(value)
        if not isinstance(value, str) or not value:
            raise self.fail(key, "must be a path (a non-empty string)")
        path = Path(value).expanduser()
        if not path.is_absolute() and self.base is not None:
            path = self.base / path
        return path

    def opt_path(self, key: str) -> Path | None:
        return self.path(key) if key in self.data else None

    def convert(self, key: str, parse: Callable[[str], T], default: T | _Missing = REQUIRED) -> T:
        """A string turned into a ``T`` by ``parse``; its ``ValueError`` names the field."""
        if key not in self.data:
            if isinstance(default, _Missing):
                raise self.fail(key, "required")
            return default
        try:
            return parse(self.text(key))
        except ValueError as exc:
            if isinstance(exc, ConfigError):
                raise
            raise self.fail(key, str(exc)) from None

    # -- collections ---------------------------------------------------------------------

    def table(
        self, key: str, keys: Iterable[str] | None = None, *, required: bool = False
    ) -> Table:
        """The sub-table ``key`` (empty if absent, unless ``required``), checked to hold only
        ``keys`` if given."""
        value = self.data[key] if self._given(key, REQUIRED if required else {}) else {}
        if not isinstance(value, Mapping):
            raise self.fail(key, f"must be a table, not {_kind(value)}")
        sub = Table(self.source, self.field(key), value)
        return sub.keys(keys) if keys is not None else sub

    def opt_table(self, key: str, keys: Iterable[str] | None = None) -> Table | None:
        return self.table(key, keys) if key in self.data else None

    def tables(
        self, key: str, keys: Iterable[str] | None = None, *, required: bool = False
    ) -> list[Table]:
        """The array of tables ``[[key]]`` (empty if absent), each checked like :meth:`table`."""
        value = self.data[key] if self._given(key, REQUIRED if required else []) else []
        name = self.field(key)
        if not isinstance(value, list):
            raise self.fail(key, f"must be an array of tables ([[{name}]])")
        out = []
        for i, item in enumerate(value):
            if not isinstance(item, Mapping):
                raise self.source.fail(f"{name}[{i}]", "must be a table")
            sub = Table(self.source, f"{name}[{i}]", item)
            out.append(sub.keys(keys) if keys is not None else sub)
        if required and not out:
            raise self.fail(key, f"at least one [[{name}]] table is required")
        return out

    def texts(
        self, key: str, default: Iterable[str] | _Missing = REQUIRED, *, empty: bool = True
    ) -> list[str]:
        """An array of strings."""
        if not self._given(key, default):
            assert not isinstance(default, _Missing)
            return list(default)
        value = self.data[key]
        if not isinstance(value, list | tuple) or not all(isinstance(v, str) for v in value):
            raise self.fail(key, "must be an array of strings")
        if not value and not empty:
            raise self.fail(key, "must not be empty")
        return [str(v) for v in value]

    def numbers(self, key: str, default: Iterable[float] | _Missing = REQUIRED) -> list[float]:
        """An array of numbers."""
        if not self._given(key, default):
            assert not isinstance(default, _Missing)
            return [float(v) for v in default]
        value = self.data[key]
        if not isinstance(value, list | tuple) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in value
        ):
            raise self.fail(key, "must be an array of numbers")
        return [float(v) for v in value]

    def text_map(self, key: str) -> dict[str, str]:
        """A table of strings (``{ T1 = "°C" }``), empty if absent."""
        value = self.data.get(key, {})
        if not isinstance(value, Mapping) or not all(isinstance(v, str) for v in value.values()):
            raise self.fail(key, 'must be a table of strings ({ NAME = "..." })')
        return {str(k): str(v) for k, v in value.items()}

    def items(self) -> Iterator[tuple[str, object]]:
        return iter(self.data.items())

    def is_table(self, key: str) -> bool:
        return isinstance(self.data.get(key), Mapping)

    def is_text(self, key: str) -> bool:
        return isinstance(self.data.get(key), str)


def _within(value: float, lo: float | None, hi: float | None) -> bool:
    return (lo is None or value >= lo) and (hi is None or value <= hi)


def _range(what: str, lo: float | None, hi: float | None) -> str:
    if lo is not None and hi is not None:
        return f"{what} {lo:g}..{hi:g}"
    if lo is not None:
        return f"{what} >= {lo:g}"
    if hi is not None:
        return f"{what} <= {hi:g}"
    return what
