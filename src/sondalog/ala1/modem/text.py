"""SMS text as the logger writes it (gsm.md §4): GSM-7 only, at most 160 characters a part.

The ALA1 core may not import :mod:`sondalog.gsm` (the import rule), so the GSM 03.38 default
alphabet is written here again: a character outside it becomes ``?``; a character of the
extension table counts 2 of the 160. The modem takes the text as ISO 8859-1 bytes
(``AT+CSCS="GSM"``): GSM-7 letters outside Latin-1 (the Greek capitals) become ``?`` too.
"""

from __future__ import annotations

#: GSM 03.38 basic set (without the escape at 0x1B).
BASIC = (
    "@£$¥èéùìòÇ\nØø\rÅåΔ_ΦΓΛΩΠΨΣΘΞÆæßÉ !\"#¤%&'()*+,-./0123456789:;<=>?"
    "¡ABCDEFGHIJKLMNOPQRSTUVWXYZÄÖÑÜ§¿abcdefghijklmnopqrstuvwxyzäöñüà"
)
EXTENSION = "^{}\\[~]|€"
SMS_SEPTETS = 160


def septets(char: str) -> int:
    return 2 if char in EXTENSION else 1


def gsm7_text(text: str) -> str:
    """``text`` with every character the logger cannot send as GSM-7 replaced by ``?``."""
    out = []
    for char in text:
        ok = (char in BASIC or char in EXTENSION) and (ord(char) < 256 or char in EXTENSION)
        out.append(char if ok and char != "€" else "?")
    return "".join(out)


def split_sms(text: str) -> list[str]:
    """``text`` (already GSM-7) cut into parts of at most 160 septets, in order."""
    parts: list[str] = []
    current: list[str] = []
    used = 0
    for char in text:
        size = septets(char)
        if used + size > SMS_SEPTETS:
            parts.append("".join(current))
            current, used = [], 0
        current.append(char)
        used += size
    if current or not parts:
        parts.append("".join(current))
    return parts


def normalize_number(number: str) -> str:
    """A phone number compared as the network does: no spaces, ``00`` -> ``+``."""
    digits = "".join(number.split()).replace("-", "")
    if digits.startswith("00"):
        digits = "+" + digits[2:]
    return digits
