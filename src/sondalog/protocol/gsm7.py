"""The GSM 03.38 (3GPP TS 23.038) default alphabet, its extension table, septet packing and UCS2.

An SMS carries at most 140 octets of user data: 160 GSM-7 characters packed seven bits each,
or 70 UCS2 characters. The logger's replies and messages are sent as GSM-7 text; characters
outside the alphabet become ``?`` and a reply longer than one SMS goes as several, each at most
160 characters, where a character of the extension table (``{``, ``€``...) counts 2
(the gsm notes (docs/gsm-notes.md) §4, manual §3.4.6.1).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

#: The default alphabet, indexed by septet value; 0x1B is the escape to the extension table.
DEFAULT_ALPHABET = (
    "@£$¥èéùìòÇ\nØø\rÅåΔ_ΦΓΛΩΠΨΣΘΞ\x1bÆæßÉ"
    " !\"#¤%&'()*+,-./0123456789:;<=>?"
    "¡ABCDEFGHIJKLMNOPQRSTUVWXYZÄÖÑÜ§"
    "¿abcdefghijklmnopqrstuvwxyzäöñüà"
)
ESCAPE = 0x1B
#: The extension table: septet after ESC -> character.
EXTENSION = {
    0x0A: "\f",
    0x14: "^",
    0x28: "{",
    0x29: "}",
    0x2F: "\\",
    0x3C: "[",
    0x3D: "~",
    0x3E: "]",
    0x40: "|",
    0x65: "€",
}
#: Septets of one SMS without a user data header.
SMS_SEPTETS = 160
#: UCS2 characters of one SMS without a user data header.
SMS_UCS2_CHARS = 70
REPLACEMENT = "?"

_BASIC = {ch: i for i, ch in enumerate(DEFAULT_ALPHABET) if i != ESCAPE}
_EXTENDED = {ch: code for code, ch in EXTENSION.items()}

assert len(DEFAULT_ALPHABET) == 128


class Gsm7Error(ValueError):
    """Text that cannot be coded in the GSM 7-bit default alphabet."""


def is_gsm7(text: str) -> bool:
    """Every character of ``text`` is in the default alphabet or its extension table."""
    return all(ch in _BASIC or ch in _EXTENDED for ch in text)


def to_gsm7(text: str) -> str:
    """``text`` with every character outside GSM-7 replaced by ``?`` (gsm.md §4)."""
    return "".join(ch if ch in _BASIC or ch in _EXTENDED else REPLACEMENT for ch in text)


def char_septets(ch: str) -> int:
    """Septets one character takes: 1, or 2 for the extension table (ESC + code)."""
    if ch in _BASIC:
        return 1
    if ch in _EXTENDED:
        return 2
    raise Gsm7Error(f"{ch!r} is not in the GSM 7-bit alphabet")


def septet_length(text: str) -> int:
    """Septets ``text`` takes, extension characters counting 2."""
    return sum(char_septets(ch) for ch in text)


def encode_septets(text: str) -> list[int]:
    """Text -> septet values; raises :class:`Gsm7Error` for a character outside GSM-7."""
    out: list[int] = []
    for ch in text:
        code = _BASIC.get(ch)
        if code is not None:
            out.append(code)
            continue
        ext = _EXTENDED.get(ch)
        if ext is None:
            raise Gsm7Error(f"{ch!r} is not in the GSM 7-bit alphabet")
        out.extend((ESCAPE, ext))
    return out


def decode_septets(septets: Iterable[int]) -> str:
    """Septet values -> text. An unknown extension code reads as its basic character
    (23.038: "the MS shall display the character from the default table"); a trailing ESC
    reads as a space."""
    out: list[str] = []
    escaped = False
    for s in septets:
        s &= 0x7F
        if escaped:
            escaped = False
            out.append(EXTENSION.get(s, DEFAULT_ALPHABET[s] if s != ESCAPE else " "))
        elif s == ESCAPE:
            escaped = True
        else:
            out.append(DEFAULT_ALPHABET[s])
    if escaped:
        out.append(" ")
    return "".join(out)


def pack_septets(septets: Sequence[int], fill_bits: int = 0) -> bytes:
    """Pack septets LSB first into octets, after ``fill_bits`` zero bits (0-6), as the user
    data of an SMS after a user data header is packed (23.040 §9.2.3.24)."""
    acc = 0
    nbits = fill_bits
    out = bytearray()
    for s in septets:
        acc |= (s & 0x7F) << nbits
        nbits += 7
        while nbits >= 8:
            out.append(acc & 0xFF)
            acc >>= 8
            nbits -= 8
    if nbits:
        out.append(acc & 0xFF)
    return bytes(out)


def unpack_septets(data: bytes, count: int, fill_bits: int = 0) -> list[int]:
    """The first ``count`` septets packed in ``data`` after ``fill_bits`` bits."""
    out: list[int] = []
    bit = fill_bits
    for _ in range(count):
        index, shift = divmod(bit, 8)
        if index >= len(data):
            raise Gsm7Error("user data shorter than its length")
        word = data[index] | (data[index + 1] << 8 if index + 1 < len(data) else 0)
        out.append((word >> shift) & 0x7F)
        bit += 7
    return out


def packed_length(septets: int, fill_bits: int = 0) -> int:
    """Octets that ``septets`` septets take after ``fill_bits`` bits."""
    return (septets * 7 + fill_bits + 7) // 8


def encode_ucs2(text: str) -> bytes:
    """Text -> UCS2 (UTF-16 big endian; characters beyond the BMP as surrogate pairs)."""
    return text.encode("utf-16-be")


def decode_ucs2(data: bytes) -> str:
    """UCS2 octets -> text; an odd last octet or a lone surrogate reads as U+FFFD."""
    return data[: len(data) - len(data) % 2].decode("utf-16-be", errors="replace")


def split_sms(text: str, limit: int = SMS_SEPTETS) -> list[str]:
    """Cut ``text`` (first made GSM-7 with :func:`to_gsm7`) into pieces of at most ``limit``
    septets each, in order, never splitting an extension character (gsm.md §4). Empty text is
    one empty SMS."""
    text = to_gsm7(text)
    parts: list[str] = []
    current: list[str] = []
    used = 0
    for ch in text:
        need = char_septets(ch)
        if used + need > limit:
            parts.append("".join(current))
            current, used = [], 0
        current.append(ch)
        used += need
    if current or not parts:
        parts.append("".join(current))
    return parts
