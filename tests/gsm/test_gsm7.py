"""GSM 03.38 alphabet, septet packing and SMS splitting (gsm.md §4)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sondalog.protocol import gsm7

GSM_CHARS = [c for i, c in enumerate(gsm7.DEFAULT_ALPHABET) if i != gsm7.ESCAPE]
GSM_TEXT = st.text(alphabet=st.sampled_from(GSM_CHARS + list(gsm7.EXTENSION.values())))


def test_known_packing_vector() -> None:
    # The classic example of 23.038 tutorials: "hellohello" packs to 9 octets.
    septets = gsm7.encode_septets("hellohello")
    assert gsm7.pack_septets(septets).hex().upper() == "E8329BFD4697D9EC37"
    assert gsm7.decode_septets(gsm7.unpack_septets(bytes.fromhex("E8329BFD4697D9EC37"), 10)) == (
        "hellohello"
    )


def test_hi_is_e834() -> None:
    assert gsm7.pack_septets(gsm7.encode_septets("hi")) == bytes.fromhex("E834")


def test_extension_characters_take_two_septets() -> None:
    assert gsm7.encode_septets("€{") == [0x1B, 0x65, 0x1B, 0x28]
    assert gsm7.septet_length("a€[]") == 7
    assert gsm7.decode_septets([0x1B, 0x65, 0x41]) == "€A"


def test_characters_outside_gsm7_become_question_marks() -> None:
    assert gsm7.to_gsm7("Teplota ≥ 5 °C, kredit 250 Kč") == "Teplota ? 5 ?C, kredit 250 K?"
    assert not gsm7.is_gsm7("č")
    with pytest.raises(gsm7.Gsm7Error):
        gsm7.encode_septets("č")


def test_ucs2() -> None:
    assert gsm7.encode_ucs2("Kč") == bytes.fromhex("004B010D")
    assert gsm7.decode_ucs2(bytes.fromhex("004B010D")) == "Kč"


@given(st.lists(st.integers(0, 127), max_size=200), st.integers(0, 6))
def test_pack_unpack_round_trip(septets: list[int], fill: int) -> None:
    packed = gsm7.pack_septets(septets, fill)
    assert len(packed) == gsm7.packed_length(len(septets), fill)
    assert gsm7.unpack_septets(packed, len(septets), fill) == septets


@given(GSM_TEXT)
def test_text_round_trip(text: str) -> None:
    septets = gsm7.encode_septets(text)
    assert len(septets) == gsm7.septet_length(text)
    assert gsm7.decode_septets(gsm7.unpack_septets(gsm7.pack_septets(septets), len(septets))) == (
        text
    )


@given(st.text(max_size=700))
def test_split_keeps_order_and_limit(text: str) -> None:
    parts = gsm7.split_sms(text)
    assert "".join(parts) == gsm7.to_gsm7(text)
    assert all(gsm7.septet_length(p) <= gsm7.SMS_SEPTETS for p in parts)
    assert all(p for p in parts) or parts == [""]


def test_split_never_cuts_an_extension_character() -> None:
    text = "x" * 159 + "€" + "y"
    parts = gsm7.split_sms(text)
    assert parts == ["x" * 159, "€y"]
    assert gsm7.split_sms("a" * 320) == ["a" * 160, "a" * 160]
    assert gsm7.split_sms("") == [""]
