"""SMS text as the logger writes it (gsm notes §4): GSM-7 only, at most 160 characters a part.

The GSM 03.38 alphabet is the shared wire format :mod:`sondalog.protocol.gsm7`: a character
outside it becomes ``?``; a character of the extension table counts 2 of the 160. The modem
takes the text as ISO 8859-1 bytes (``AT+CSCS="GSM"``), so GSM-7 letters outside Latin-1 (the
Greek capitals, ``€``) become ``?`` too.
"""

from __future__ import annotations

from sondalog.protocol.gsm7 import split_sms, to_gsm7

__all__ = ["gsm7_text", "normalize_number", "split_sms"]


def gsm7_text(text: str) -> str:
    """``text`` with every character the logger cannot send as GSM-7 replaced by ``?``."""
    return "".join(c if ord(c) < 256 else "?" for c in to_gsm7(text))


def normalize_number(number: str) -> str:
    """A phone number compared as the network does: no spaces, ``00`` -> ``+``."""
    digits = "".join(number.split()).replace("-", "")
    if digits.startswith("00"):
        digits = "+" + digits[2:]
    return digits
