"""The typed configuration reader: every getter's refusals name file, line and field."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sondalog.config import ConfigError, is_loopback, load, loads, of, parse_listen

TEXT = """\
[web]
listen = "127.0.0.1:8080"
enabled = true

[[source]]
url = "tcp://127.0.0.1:10001"
interval = 60

[[source]]
url = "tcp://127.0.0.1:10002"
interval = -1
flag = "yes"
"""


def _error(text: str, call: object) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        assert callable(call)
        call(loads(text, Path("site.toml")))
    return info.value


def test_typed_getters_read_values() -> None:
    root = loads(TEXT, Path("/etc/s/site.toml"))
    web = root.table("web", keys={"listen", "enabled"})
    assert web.address("listen") == ("127.0.0.1", 8080)
    assert web.flag("enabled") is True
    assert web.flag("absent", False) is False
    sources = root.tables("source")
    assert [s.text("url") for s in sources] == ["tcp://127.0.0.1:10001", "tcp://127.0.0.1:10002"]
    assert sources[0].number("interval", above=0) == 60.0
    assert sources[0].integer("interval", lo=1, hi=3600) == 60
    assert sources[0].number("timeout", 5) == 5.0
    assert sources[0].path("store", "a.sqlite") == Path("/etc/s/a.sqlite")


def test_refusals_name_file_line_and_field() -> None:
    error = _error(TEXT, lambda r: r.tables("source")[1].number("interval", above=0))
    assert str(error) == "site.toml:11: source[1].interval: must be a number > 0, not -1"
    assert (error.line, error.field) == (11, "source[1].interval")
    error = _error(TEXT, lambda r: r.tables("source")[1].flag("flag"))
    assert str(error) == "site.toml:12: source[1].flag: must be true or false, not 'yes'"
    error = _error(TEXT, lambda r: r.table("web").integer("listen"))
    assert "site.toml:2: web.listen: must be an integer" in str(error)
    error = _error(TEXT, lambda r: r.table("web").text("missing"))
    assert str(error) == "site.toml:1: web.missing: required"


def test_unknown_keys_and_tables_get_a_did_you_mean() -> None:
    error = _error("[loger]\nseed = 1\n", lambda r: r.keys({"logger", "bus"}))
    assert str(error).startswith(
        "site.toml:1: loger: unknown table or key 'loger' (did you mean logger?"
    )
    error = _error(TEXT, lambda r: r.tables("source", keys={"url", "interval"}))
    assert "site.toml:12: source[1].flag: unknown" in str(error)


def test_true_is_not_an_integer_nor_a_number() -> None:
    for getter in ("integer", "number"):
        error = _error("x = true\n", lambda r, g=getter: getattr(r, g)("x"))
        assert str(error).startswith("site.toml:1: x: must be")


def test_shapes_are_checked() -> None:
    assert "must be a table" in str(_error("web = 1\n", lambda r: r.table("web")))
    assert "array of tables" in str(_error("source = 1\n", lambda r: r.tables("source")))
    assert "must be a table" in str(_error("source = [1]\n", lambda r: r.tables("source")))
    assert "array of strings" in str(_error("m = [1]\n", lambda r: r.texts("m")))
    assert "one of a, b" in str(_error('k = "c"\n', lambda r: r.text("k", choices=["a", "b"])))
    assert "HOST:PORT" in str(_error('l = "nope"\n', lambda r: r.address("l")))
    assert "port must be" in str(_error('l = "h:70000"\n', lambda r: r.address("l")))
    assert "non-empty" in str(_error('k = ""\n', lambda r: r.text("k")))


def test_data_without_a_file_names_the_field() -> None:
    body = of({"number": 7}, where="body")
    with pytest.raises(ConfigError, match=r"^<config>: body.number: must be a string"):
        body.text("number")


def test_load_refuses_what_is_not_a_small_utf8_regular_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b'a = "\xff"\n')
    with pytest.raises(ConfigError, match="not UTF-8"):
        load(bad)
    link = tmp_path / "zero.toml"
    os.symlink("/dev/zero", link)
    with pytest.raises(ConfigError, match="not a regular file"):
        load(link)
    inf = tmp_path / "inf.toml"
    inf.write_text("[x]\ninterval = 1e309\n")
    with pytest.raises(ConfigError, match=r"inf.toml:2: x.interval: inf is not a finite number"):
        load(inf)


@given(st.text(max_size=40))
def test_address_parser_never_raises_anything_but_value_error(text: str) -> None:
    try:
        host, port = parse_listen(text)
    except ValueError:
        return
    assert 0 <= port <= 65535 and host


def test_loopback() -> None:
    assert is_loopback("127.0.0.2") and is_loopback("::1") and is_loopback("localhost")
    assert not is_loopback("0.0.0.0") and not is_loopback("example.net")


def test_lines_of_whole_arrays_and_quoted_keys() -> None:
    text = '[gsm]\nx = 1\n\n[[gsm.phones]]\nnumber = "1"\n\n[loggers]\n"a@b.net" = 5\n'
    root = loads(text, Path("s.toml"))
    error = _error(text, lambda r: r.table("gsm").keys({"x"}))
    assert str(error).startswith("site.toml:4: gsm.phones: unknown")
    error = _error(text, lambda r: r.table("loggers").text("a@b.net"))
    assert str(error) == 'site.toml:8: loggers."a@b.net": must be a string, not an integer'
    assert root.table("loggers").field("a@b.net") == 'loggers."a@b.net"'
