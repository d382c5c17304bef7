"""The host's station schema against the logger's parameter tree (docs/decisions.md
"Station files: the host's own schema"): every configurable leaf is covered, with the same
factory value and a grammar that accepts nothing the logger refuses."""

from __future__ import annotations

import string

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1 import Version
from sondalog.ala1 import values as core
from sondalog.ala1.model import LIMITS as CORE_LIMITS
from sondalog.ala1.params import LEAVES
from sondalog.app.virtual import VirtualLogger
from sondalog.client import station_grammar as host
from sondalog.client.station_logger import clean, desired_values, display
from sondalog.client.station_schema import SETTINGS, instances

#: Stored, readable and writable leaves that are state, not configuration.
NOT_CONFIGURATION = {"record last {pt} read"}
VERSIONS = [v.value for v in Version]


def _configurable() -> list[str]:
    patterns = []
    for leaf in LEAVES:
        if not leaf.stored or leaf.access != "RW" or leaf.pattern in NOT_CONFIGURATION:
            continue
        if "{tab}" in leaf.pattern:
            patterns += [leaf.pattern.replace("{tab}", str(t)) for t in (1, 2)]
        else:
            patterns.append(leaf.pattern)
    return patterns


def _leaf(pattern: str):  # type: ignore[no-untyped-def]
    for leaf in LEAVES:
        same = leaf.pattern.replace("{tab}", pattern[-11:-10]) == pattern
        if leaf.stored and leaf.access == "RW" and same:
            return leaf
    raise KeyError(pattern)


def test_every_configurable_leaf_is_a_setting_and_nothing_else() -> None:
    assert sorted(_configurable()) == sorted(s.pattern for s in SETTINGS)


@pytest.mark.parametrize("setting", SETTINGS, ids=lambda s: s.pattern)
@pytest.mark.parametrize("version", VERSIONS)
def test_same_kind_of_value_and_same_bounds(setting, version: str) -> None:  # type: ignore[no-untyped-def]
    leaf = _leaf(setting.pattern)
    vtype, grammar = leaf.vtype, setting.grammar
    lim, hlim = CORE_LIMITS[Version(version)], host.LIMITS[version]
    assert type(vtype).__name__ == type(grammar).__name__
    assert leaf.dual == setting.dual
    assert leaf.section == "§" + setting.section
    match vtype:
        case core.Integer():
            assert (vtype.lo, vtype.high(lim)) == (grammar.lo, host._bound(grammar.hi, hlim))
        case core.Text():
            assert vtype.max_len == grammar.max_len
        case core.OneOf():
            assert vtype.options == grammar.options
        case core.Choice():
            assert vtype.options == grammar.options
            assert {k: v.high(lim) for k, v in vtype.with_arg.items()} == {
                k: host._bound(v, hlim) for k, v in grammar.with_arg
            }
        case core.Number():
            assert (vtype.lo, vtype.special) == (grammar.lo, grammar.special)
        case core.Period():
            assert vtype.month == grammar.month
        case core.MemorySize():
            assert vtype.minimum == grammar.minimum
        case core.IntList():
            assert vtype.max_count(lim) == hlim.addresses_per_message
            assert vtype.item.high(lim) == hlim.addresses
        case core.ChannelAddress():
            assert lim.channel_address_max == hlim.channel_address_max


@pytest.mark.parametrize("version", VERSIONS)
def test_factory_values_are_what_a_fresh_logger_reads(version: str) -> None:
    logger = VirtualLogger(version=Version(version), serial_number="F-17")
    try:
        wanted = desired_values({}, version, "F-17")
        for setting, n in instances(host.LIMITS[version]):
            name = setting.name(n)
            answer = logger.command(f"read {name}{' all' if setting.dual else ''}")
            value, ok = answer.split("\r\n")[:2]
            assert ok == "OK", (name, answer)
            assert clean(setting, value) == display(setting, n, wanted[name], wanted), name
    finally:
        logger.close()


_PRINTABLE = string.ascii_letters + string.digits + " ./,-*#|!~"
CANDIDATES = st.one_of(
    st.integers(-3, 70_000).map(str),
    st.integers(0, 2**64 + 5).map(str),
    st.from_regex(r"-?[0-9]{1,5}(\.[0-9]{1,4})?", fullmatch=True),
    st.from_regex(r"[0-9]{2}[0-9]{2}[0-9]{2}", fullmatch=True),
    st.from_regex(r"(19|20|99)[0-9]{2}(0[0-9]|1[0-3])[0-3][0-9]([0-6][0-9]){3}", fullmatch=True),
    st.from_regex(r"99[0-9]{2}[0-9]{2}|999901|[0-9]\.[0-9]", fullmatch=True),
    st.sampled_from(["ds18b20", "MSP430TA", "ringvoice 3", "RINGDATA,41", "RINGVOICE,2", "no",
                     "NO", "1", "0", "up", "1,2,3", "1,2,3,4,5,6,7,8,9,10,11", "0,1", "41",
                     "cyclic", "linear", "wavecom42", "follow", "4096", "256", "1048576", "9600"]),
    st.text(alphabet=_PRINTABLE, max_size=24),
)  # fmt: skip


def _d2(lo: int, hi: int) -> st.SearchStrategy[str]:
    return st.integers(lo, hi).map(lambda v: f"{v:02d}")


def _near(setting, limits) -> st.SearchStrategy[str]:  # type: ignore[no-untyped-def]
    """Values of the setting's kind, many near its bounds."""
    g = setting.grammar
    if isinstance(g, host.Integer):
        hi = host._bound(g.hi, limits)
        return st.one_of(st.integers(g.lo - 2, hi + 2), st.sampled_from([hi, hi + 1])).map(str)
    if isinstance(g, host.Period):
        return st.one_of(
            st.tuples(_d2(0, 99), _d2(0, 99), _d2(0, 99)).map("".join),
            st.tuples(st.just("99"), _d2(85, 95), _d2(0, 30)).map("".join),
            st.tuples(_d2(94, 98), _d2(0, 61), _d2(0, 61)).map("".join),
            st.sampled_from(["999901", "960000", "960001", "990000"]),
        )
    if isinstance(g, host.Date):
        return st.tuples(
            st.integers(0, 2100).map(lambda y: f"{y:04d}"), _d2(0, 13), _d2(0, 32),
            _d2(0, 25), _d2(0, 61), _d2(0, 61),
        ).map("".join)  # fmt: skip
    if isinstance(g, host.Text):
        return st.text(alphabet=_PRINTABLE, max_size=(g.max_len or 40) + 3)
    if isinstance(g, host.Choice | host.OneOf):
        options = [str(o) for o in g.options]
        return st.one_of(
            st.sampled_from(options), st.sampled_from(options).map(str.lower),
            st.tuples(st.sampled_from(options), st.integers(0, 42)).map(lambda t: f"{t[0]},{t[1]}"),
        )  # fmt: skip
    if isinstance(g, host.IntList):
        return st.lists(st.integers(0, 42).map(str), min_size=1, max_size=11).map(",".join)
    return CANDIDATES


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    version=st.sampled_from(VERSIONS),
    setting=st.sampled_from(SETTINGS),
    n=st.integers(1, 40),
    data=st.data(),
)
def test_what_the_host_accepts_the_logger_takes_and_reads_back(  # type: ignore[no-untyped-def]
    version: str, setting, n: int, data
) -> None:
    text = data.draw(st.one_of(_near(setting, host.LIMITS[version]), CANDIDATES))
    limits = host.LIMITS[version]
    n = (n - 1) % setting.count(limits) + 1
    try:
        value = setting.grammar.check(text, limits)
    except ValueError:
        return  # the host refuses: nothing is sent (stricter than the logger is allowed)
    if setting.dual:
        value = f"{value},{value}"
    logger = VirtualLogger(version=Version(version))
    try:
        if setting.pattern == "file list size" or setting.pattern == "file data size":
            logger.command("write file record size 256")
            if int(value) > 1048576 - 256:
                return  # the areas share the memory with the record's 256 (§6.15): refused
        dual = " all" if setting.dual else ""
        line = f"write {setting.name(n)}{dual}{setting.grammar.written(value)}"
        if host.fits_line(line):
            return
        answer = logger.command(line)
        if setting.pattern == "com device mode":
            return
        assert answer == "OK\r\n", (line, answer)
        prefix = f"iaddress/{value}/ " if setting.pattern == "i address" and value else ""
        if prefix and "/" in value:
            prefix = f"iaddress|{value}| "
        back = logger.command(f"{prefix}read {setting.name(n)}{dual}").split("\r\n")[0]
        values = desired_values({setting.name(n): value}, version, "000001")
        assert clean(setting, back) == display(setting, n, value, values), line
        for part in clean(setting, back).split(",") if setting.dual else [clean(setting, back)]:
            if setting.fmt is None:
                setting.grammar.check(part, limits)  # what the logger reads back, the host takes
    finally:
        logger.close()
