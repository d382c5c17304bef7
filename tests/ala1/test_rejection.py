"""The parser's structured rejection (issue 25, item 4): where, what, what it expected."""

from __future__ import annotations

from sondalog.ala1.model import Identity, Version
from sondalog.ala1.parser import parse_line
from sondalog.ala1.rejection import Rejection
from sondalog.ala1.state import ModuleState
from sondalog.backends.store.ala1_nv import SqliteNvStore


def reject(line: str) -> Rejection | None:
    state = ModuleState(Identity(Version.V2_10), SqliteNvStore(":memory:"), 0.0)
    view = state.begin(0.0)
    try:
        return parse_line(line, view).rejection
    finally:
        view.rollback()


def test_a_refused_line_names_position_token_expected_and_section() -> None:
    found = reject("read channel 1 nme")
    assert found is not None
    assert (found.position, found.token, found.what, found.section) == (15, "nme", "keyword", "§6")
    assert "name" in found.expected and "value" in found.expected
    assert found.subject == "channel 1"


def test_value_chain_header_and_channel_rejections() -> None:
    value = reject("write com speed 1234")
    assert value is not None and (value.what, value.token, value.expected) == (
        "value",
        "1234",
        ("integer",),
    )
    chain = reject("read i version foo")
    assert chain is not None and chain.what == "chain" and chain.section == "§7"
    assert chain.expected == ("read", "write", "i ...")
    header = reject("check abc read date")
    assert header is not None and (header.what, header.subject, header.token) == (
        "header",
        "check",
        "abc",
    )
    channel = reject("write channel 1 3 13 name /a/")
    assert channel is not None and (channel.position, channel.token) == (18, "13")


def test_an_accepted_line_has_no_rejection() -> None:
    assert reject("sum read channel 1 3 value read i version") is None
