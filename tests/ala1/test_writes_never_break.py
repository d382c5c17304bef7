"""Issue 9: nothing acknowledged may break a logger.

For every writable leaf of the parameter table, in both protocol versions, with sampling
running: a written value either gets the error response or reads back, and the module still
answers ``read i version`` afterwards and after a restart on the same memory.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from ala1_module import Module
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1 import Version
from sondalog.ala1.hardware import NoHardware
from sondalog.ala1.params import LEAVES, Leaf
from sondalog.ala1.values import (
    ChannelAddress,
    Date,
    Integer,
    IntList,
    Number,
    OneOf,
    OptionalInteger,
    Period,
)

#: Leaves whose write changes how the line itself works (tested on their own elsewhere).
_LINE_CHANGING = ("i address", "com speed", "com comspeed", "com flow", "com device")

NUMERIC = (Number, Integer, OneOf, ChannelAddress, Date, Period, IntList)


def _writable(leaf: Leaf) -> bool:
    return (
        "W" in leaf.access
        and isinstance(leaf.vtype, NUMERIC)
        and not leaf.ends_line
        and leaf.unavailable is None
        and leaf.writer is None
        and not leaf.pattern.startswith(_LINE_CHANGING)
    )


LEAF_PATTERNS = sorted({leaf.pattern for leaf in LEAVES if _writable(leaf)})
_BY_PATTERN = {leaf.pattern: leaf for leaf in LEAVES}

#: Hand-picked forms: boundaries, huge, tiny, negative, many digits, exponent forms.
EDGE_VALUES = [
    "0",
    "-1",
    "1",
    "65535",
    "65536",
    "4294967296",
    "18446744073709551616",
    "999999999999999",
    "1000000000000000",
    "-999999999999999.999",
    "-1000000000000000",
    "10000000000000000000000000000",
    "-10000000000000000000000000000",
    "0.000000000000000000000000000001",
    "123456789012345678901234567890.123456789",
    "1e5",
    "1E+30",
    "-0.0",
    "99991231235959",
    "00010101000000",
    "999901",
    "999999",
    "0000000000000000000000000000000000000000000007",
]

numbers = st.one_of(
    st.sampled_from(EDGE_VALUES),
    st.integers(min_value=-(10**40), max_value=10**40).map(str),
    st.decimals(allow_nan=False, allow_infinity=False, places=6).map(lambda d: format(d, "f")),
)


def _path(leaf: Leaf) -> str:
    words = []
    for word in leaf.pattern.split():
        words.append("1" if word.startswith("{") else word)
    return " ".join(words)


def _sampling(module: Module) -> None:
    """Two channels sampling every second, recording every sample."""
    module.ok("write channel max number 2")
    for ch in (1, 2):
        module.ok(f"write channel {ch} type 1")
        module.ok(f"write channel {ch} sampling period 000001")
        module.ok(f"write channel {ch} record change 0")


@pytest.mark.parametrize("version", [Version.V1_16, Version.V2_10])
@pytest.mark.parametrize("pattern", LEAF_PATTERNS)
@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(value=numbers)
def test_a_write_either_fails_or_reads_back(
    version: Version, pattern: str, value: str, tmp_path: Path
) -> None:
    leaf = _BY_PATTERN[pattern]
    module = Module(version)
    try:
        _sampling(module)
        path = _path(leaf)
        answer = module.ask(f"write {path} {value}") + module.advance(2.0)
        if answer == b"OK\r\n" and "R" in leaf.access:
            back = module.ask(f"read {path}") + module.advance(2.0)
            assert back.endswith(b"\r\nOK\r\n"), (path, value, back)
        else:
            assert answer in (b"OK\r\n", f"write {path} {value}"[:120].encode() + b"\r\nERROR\r\n")
        assert module.ask("read i version").endswith(b"\r\nOK\r\n"), (path, value)
        assert module.ask("read channel 1 sample").endswith(b"\r\nOK\r\n"), (path, value)
    finally:
        module.store.close()


@pytest.mark.parametrize(
    "command",
    [
        "write channel 1 cal mult value 10000000000000000000000000000",
        "write channel 1 cal add value -10000000000000000000000000000",
        "write channel 1 cal2 mult 1000000000000000",
        "write channel 1 record change 1000000000000000",
        "write device 1 cal mult 1000000000000000",
        "write message 1 of channel value 1000000000000000",
    ],
)
def test_the_issue_9_numbers_are_refused(module: Module, command: str) -> None:
    module.error(command)


class _Supply(NoHardware):
    """A module whose supply divider reads a steady value."""

    def supply(self, t: float) -> float | None:
        return 0.5


def test_a_huge_computed_value_reads_as_no_value_and_other_channels_go_on() -> None:
    """A value beyond 15 digits is no valid value; the other channel still records."""
    module = Module(hardware=_Supply())
    module.ok("write channel max number 2")
    for ch in (1, 2):
        module.ok(f"write channel {ch} type 1")
        module.ok(f"write channel {ch} sampling period 000001")
        module.ok(f"write channel {ch} record change 0")
    module.ok("write channel 1 cal mult value 999999999999999")
    module.ok("write channel 1 cal2 mult 999999999999999")
    module.advance(3.0)
    assert module.read("read channel 1 sample") == ""
    rows = module.ask("read record 100 from start").decode().splitlines()
    assert rows[-1] == "OK" and len(rows) >= 4
    for row in rows[-4:-1]:
        fields = row.split(",")
        assert fields[2] == "" and fields[3] != "", row  # channel 2 still records
    assert module.ask("read i version").endswith(b"OK\r\n")


def test_the_clock_holds_at_the_end_of_the_calendar(module: Module) -> None:
    """docs/decisions.md: the module clock stops at 99991231235959 instead of overflowing."""
    _sampling(module)
    module.ok("write date 99991231235958")
    module.advance(5.0)
    assert module.read("read date") == "99991231235959"
    module.advance(3600.0)
    assert module.read("read date") == "99991231235959"
    assert module.engine.next_deadline() is None or module.engine.next_deadline() > module.now
    assert module.ask("read i version").endswith(b"OK\r\n")
    module.ok("write date 20260101000000")
    module.advance(1.0)
    assert module.read("read date") == "20260101000001"


def test_unusable_stored_values_are_repaired_at_start(tmp_path: Path) -> None:
    """A value that cannot be used goes back to its factory value, only that one."""
    db = tmp_path / "nv.sqlite"
    module = Module(db=db)
    module.ok("write channel 1 name /kept/")
    module.ok("write channel 1 type 1")
    module.ok("write channel 1 sampling period 000001")
    factory = module.read("read channel 1 cal mult value")
    module.store.conn.executemany(
        "INSERT OR REPLACE INTO param (logger, key, value) VALUES ('', ?, ?)",
        [
            ("channel 1 cal mult value", "10000000000000000000000000000"),
            ("channel 2 record change", "x"),
        ],
    )
    module.store.conn.commit()
    module.store.close()
    again = Module(db=db)
    try:
        assert again.ask("read i version").endswith(b"OK\r\n")
        assert again.read("read channel 1 cal mult value") == factory
        assert again.read("read channel 1 name") == "/kept/"
        assert again.read("read channel 1 sampling period") == "000001"
        again.advance(2.0)
        assert again.ask("read channel 1 sample").endswith(b"OK\r\n")
    finally:
        again.store.close()


def test_changing_sampling_keeps_the_last_sample(module: Module) -> None:
    """Issue 10's bug: §6.5.9, §6.5.16.3 — the last sample stays until a new one."""
    module.ok("write channel 1 type 1")
    module.ok("write channel 1 sampling period 000001")
    module.ok("write channel 1 record change 0.5")
    module.advance(1.0)
    sample = module.read("read channel 1 sample")
    recorded = module.read("read channel 1 record value")
    module.ok("write channel 1 sampling period 000000")
    assert module.read("read channel 1 sample") == sample
    assert module.read("read channel 1 record value") == recorded
    rows_before = module.ask("read record status")
    module.ok("write channel 1 sampling period 000001")
    module.advance(1.0)
    # the value did not change by 0.5: the change rule does not record it again
    assert module.ask("read record status") == rows_before


def test_optional_integer_is_covered() -> None:
    assert any(isinstance(_BY_PATTERN[p].vtype, OptionalInteger | Integer) for p in LEAF_PATTERNS)
