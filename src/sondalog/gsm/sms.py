"""Short messages at the SMS centre: the record, number normalization, splitting a long text
into the parts of a concatenated SMS and joining them back (3GPP TS 23.040 §9.2.3.24.1).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from sondalog.gsm.pdu import GSM7, Concat
from sondalog.protocol import gsm7

#: The SMS centre's number (``AT+CSCA?``) unless a site file's ``[gsm]`` names another.
DEFAULT_SMSC = "+420603052000"


@dataclass(frozen=True, slots=True)
class Sms:
    """A short message at the SMS centre; ``timestamp`` is when the centre took it."""

    sms_id: int
    sender: str
    to: str
    text: str
    timestamp: int
    alphabet: str = "gsm7"
    concat: Concat | None = None


def parts_of(text: str, alphabet: str) -> list[str]:
    """``text`` as one SMS, or as the parts of a concatenated SMS (153 septets or 67 UCS2
    characters each, room left for the concatenation header)."""
    if alphabet == GSM7:
        if gsm7.septet_length(text) <= gsm7.SMS_SEPTETS:
            return [text]
        return gsm7.split_sms(text, 153)
    units = len(gsm7.encode_ucs2(text)) // 2
    if units <= gsm7.SMS_UCS2_CHARS:
        return [text]
    parts: list[str] = []
    current = ""
    for ch in text:
        if len(gsm7.encode_ucs2(current + ch)) // 2 > 67:
            parts.append(current)
            current = ""
        current += ch
    return [*parts, current]


def normalize(number: str) -> str:
    """``00420...`` -> ``+420...``; spaces and dashes removed."""
    number = "".join(ch for ch in number.strip() if ch not in " -()")
    return "+" + number[2:] if number.startswith("00") else number


def joined(messages: list[Sms]) -> list[Sms]:
    """``messages`` with each complete concatenated SMS joined into one (its first part's
    id and timestamp, no ``concat``); incomplete ones stay as parts, in arrival order."""
    groups: dict[tuple[str, int, int], dict[int, Sms]] = {}
    for sms in messages:
        if sms.concat is not None:
            key = (sms.sender, sms.concat.ref, sms.concat.total)
            groups.setdefault(key, {})[sms.concat.seq] = sms
    out: list[Sms] = []
    done: set[tuple[str, int, int]] = set()
    for sms in messages:
        if sms.concat is None:
            out.append(sms)
            continue
        key = (sms.sender, sms.concat.ref, sms.concat.total)
        parts = groups[key]
        if len(parts) != sms.concat.total or set(parts) != set(range(1, sms.concat.total + 1)):
            out.append(sms)
        elif key not in done:
            done.add(key)
            text = "".join(parts[i].text for i in range(1, sms.concat.total + 1))
            out.append(replace(parts[1], text=text, concat=None))
    return out
