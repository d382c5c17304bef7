"""SMS-SUBMIT and SMS-DELIVER PDUs, byte-exact (23.040 §9.2; recipes.md §5)."""

from __future__ import annotations

import calendar

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sondalog.gsm import pdu
from sondalog.protocol import gsm7

GAMMU_PDU = "079124603050020011000C912470000000100000FF02E834"


def test_decode_what_gammu_sends() -> None:
    raw = bytes.fromhex(GAMMU_PDU)
    assert pdu.tpdu_length(raw) == 16
    sms = pdu.decode_submit(raw)
    assert sms.smsc == "+420603052000"
    assert sms.destination == "+420700000001"
    assert sms.text == "hi"
    assert (sms.mr, sms.pid, sms.dcs, sms.validity) == (0, 0, 0, b"\xff")
    assert sms.alphabet == pdu.GSM7 and sms.concat is None


def test_encode_submit_is_byte_exact() -> None:
    raw = pdu.encode_submit("+420700000001", "hi", smsc="+420603052000")
    assert raw.hex().upper() == GAMMU_PDU


def test_decode_classic_deliver_vector() -> None:
    raw = bytes.fromhex("07917283010010F5040BC87238880900F10000993092516195800AE8329BFD4697D9EC37")
    sms = pdu.decode_deliver(raw)
    assert sms.smsc == "+27381000015"
    assert sms.originator == "27838890001"
    assert sms.text == "hellohello"
    assert sms.tz_quarters == 8
    assert sms.timestamp == calendar.timegm((1999, 3, 29, 13, 16, 59, 0, 0, 0))


def test_encode_deliver_is_byte_exact() -> None:
    stamp = calendar.timegm((2026, 11, 30, 1, 2, 3, 0, 0, 0))  # 02:02:03 at UTC+1
    raw = pdu.encode_deliver("+420700000001", "hi", stamp, tz_quarters=4, smsc="+420603052000")
    assert raw.hex().upper() == ("0791246030500200040C9124700000001000006211032020304002E834")


def test_ucs2_and_alphanumeric() -> None:
    raw = pdu.encode_deliver("Operator", "Kč", 0)
    sms = pdu.decode_deliver(raw)
    assert (sms.originator, sms.text, sms.dcs) == ("Operator", "Kč", 0x08)


def test_concatenated_7bit_has_fill_bits() -> None:
    concat = pdu.Concat(ref=0x42, total=2, seq=1)
    raw = pdu.encode_submit("+420700000001", "hello", concat=concat)
    # UDL 7 (header) + 5 septets; header 050003420201, then 1 fill bit before the septets
    assert raw.hex().upper().endswith("0C050003420201D06536FB0D")
    sms = pdu.decode_submit(raw)
    assert (sms.text, sms.concat) == ("hello", concat)


@pytest.mark.parametrize(
    ("first_vp", "vp"),
    [("01", ""), ("11", "A7"), ("09", "01" + "00" * 6), ("19", "62110320103040")],
)
def test_validity_period_variants(first_vp: str, vp: str) -> None:
    hex_pdu = "00" + first_vp + "07" + "0C91247000000010" + "0000" + vp + "02E834"
    sms = pdu.decode_submit(bytes.fromhex(hex_pdu))
    assert (sms.text, sms.mr, sms.validity.hex().upper()) == ("hi", 7, vp)


@pytest.mark.parametrize(
    "hex_pdu",
    [
        "",  # empty
        "0011000C9124700000",  # ends inside the address
        "0011000C912470000000100000FF05E834",  # UDL longer than the data
        "0001000C912470000000100020FF02E834"[:-6] + "02E834",  # compressed DCS
        "0000000C912470000000100000FF02E834",  # an SMS-DELIVER type, not a SUBMIT
    ],
)
def test_bad_pdus_raise(hex_pdu: str) -> None:
    with pytest.raises(pdu.PduError):
        pdu.decode_submit(bytes.fromhex(hex_pdu))


def test_too_long_text_does_not_fit() -> None:
    with pytest.raises(pdu.PduError):
        pdu.encode_submit("+420700000001", "a" * 161)
    assert pdu.encode_submit("+420700000001", "a" * 160)  # exactly one SMS


GSM_CHARS = [c for i, c in enumerate(gsm7.DEFAULT_ALPHABET) if i != gsm7.ESCAPE]
NUMBERS = st.from_regex(r"\+[1-9][0-9]{6,14}", fullmatch=True)
CONCAT = st.none() | st.builds(
    pdu.Concat, st.integers(0, 255), st.integers(1, 255), st.integers(1, 255)
)


@given(NUMBERS, st.text(st.sampled_from(GSM_CHARS), max_size=150), CONCAT, st.integers(0, 255))
def test_submit_round_trip_gsm7(number: str, text: str, concat: pdu.Concat | None, mr: int) -> None:
    raw = pdu.encode_submit(number, text, mr=mr, concat=concat, smsc="+420603052000")
    sms = pdu.decode_submit(raw)
    assert (sms.destination, sms.text, sms.concat, sms.mr) == (number, text, concat, mr)
    assert sms.smsc == "+420603052000"


@given(
    NUMBERS,
    st.text(st.characters(max_codepoint=0xFFFF, exclude_categories=("Cs",)), max_size=70),
    st.integers(86400, calendar.timegm((2069, 12, 30, 0, 0, 0, 0, 0, 0))),
    st.integers(-48, 56),
)
def test_deliver_round_trip_ucs2(number: str, text: str, stamp: int, tz: int) -> None:
    raw = pdu.encode_deliver(number, text, stamp, tz_quarters=tz, alphabet=pdu.UCS2)
    sms = pdu.decode_deliver(raw)
    # two-digit years: the round trip holds within 1970-2069
    assert (sms.originator, sms.text, sms.tz_quarters, sms.timestamp) == (number, text, tz, stamp)
