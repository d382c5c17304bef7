"""SMS PDUs (3GPP TS 23.040 §9.2): SMS-SUBMIT and SMS-DELIVER, coded and decoded.

In PDU mode (``AT+CMGF=0``) the DTE hands the modem an SMS-SUBMIT, SMSC part first, as hex
after ``AT+CMGS=<TPDU octets>`` (what gammu sends, ``recipes.md`` §5), and reads stored SMS
as SMS-DELIVER PDUs (``AT+CMGR``/``AT+CMGL``). Supported: addresses international, national
and alphanumeric; DCS GSM 7-bit, 8-bit data and UCS2; validity period absent, relative,
enhanced or absolute; user data with a header and the concatenation elements (8- and 16-bit
reference). Anything else raises :class:`PduError`, which the modem answers with
``+CMS ERROR: 304`` (invalid PDU mode parameter).
"""

from __future__ import annotations

import calendar
from dataclasses import dataclass
from datetime import UTC, datetime

from sondalog.protocol import gsm7

GSM7 = "gsm7"
DATA8 = "8bit"
UCS2 = "ucs2"

#: Octets of user data in one SMS (23.040 §9.2.3.24).
MAX_USER_DATA = 140

MTI_DELIVER = 0
MTI_SUBMIT = 1


class PduError(ValueError):
    """A PDU this module cannot read."""


@dataclass(frozen=True, slots=True)
class Concat:
    """Concatenated SMS information element: part ``seq`` of ``total`` of message ``ref``."""

    ref: int
    total: int
    seq: int
    wide: bool = False  # 16-bit reference (IE 0x08) instead of 8-bit (IE 0x00)


@dataclass(frozen=True, slots=True)
class SmsSubmit:
    """A decoded SMS-SUBMIT TPDU (23.040 §9.2.2.2)."""

    destination: str
    text: str
    smsc: str | None = None
    mr: int = 0
    pid: int = 0
    dcs: int = 0
    validity: bytes = b""  # the raw TP-VP octets (absent, 1 or 7)
    concat: Concat | None = None
    data: bytes = b""  # the user data after the header (octets for 8-bit, else coded text)
    status_report: bool = False
    reject_duplicates: bool = False
    reply_path: bool = False

    @property
    def alphabet(self) -> str:
        return alphabet_of(self.dcs)


@dataclass(frozen=True, slots=True)
class SmsDeliver:
    """A decoded SMS-DELIVER TPDU (23.040 §9.2.2.1); ``timestamp`` is POSIX seconds and
    ``tz_quarters`` the sender's offset from UTC in quarter hours."""

    originator: str
    text: str
    timestamp: int
    tz_quarters: int = 0
    smsc: str | None = None
    pid: int = 0
    dcs: int = 0
    concat: Concat | None = None
    data: bytes = b""
    more_messages: bool = False


# -- fields ------------------------------------------------------------------------------
def alphabet_of(dcs: int) -> str:
    """The alphabet a data coding scheme (23.038 §4) names: gsm7, 8bit or ucs2."""
    group = dcs >> 4
    if group <= 0b0111:  # general data coding (and its automatic-deletion variant)
        if dcs & 0x20:
            raise PduError(f"compressed user data (DCS {dcs:02X}) is not supported")
        return (GSM7, DATA8, UCS2, GSM7)[(dcs >> 2) & 3]
    if group in (0b1100, 0b1101):
        return GSM7
    if group == 0b1110:
        return UCS2
    if group == 0b1111:
        return DATA8 if dcs & 0x04 else GSM7
    raise PduError(f"reserved data coding scheme {dcs:02X}")


def dcs_for(alphabet: str) -> int:
    return {GSM7: 0x00, DATA8: 0x04, UCS2: 0x08}[alphabet]


def _bcd(digits: str) -> bytes:
    if len(digits) % 2:
        digits += "F"
    return bytes(int(digits[i + 1], 16) << 4 | int(digits[i], 16) for i in range(0, len(digits), 2))


def _unbcd(data: bytes, count: int) -> str:
    digits = "".join(f"{b & 0x0F:X}{b >> 4:X}" for b in data)[:count]
    return digits.translate(str.maketrans("ABCDE", "*#abc"))


def encode_address(number: str) -> bytes:
    """TP-DA/TP-OA: digit count, type of address, swapped BCD (``+420700000001`` ->
    ``0C91247000000010``). A number with letters goes as alphanumeric (TON 5)."""
    if number.startswith("+") and number[1:].isdigit():
        return bytes((len(number) - 1, 0x91)) + _bcd(number[1:])
    if number.isdigit() or not number:
        return bytes((len(number), 0x81)) + _bcd(number)
    septets = gsm7.encode_septets(gsm7.to_gsm7(number))
    packed = gsm7.pack_septets(septets)
    return bytes((len(packed) * 2, 0xD0)) + packed


def decode_address(data: bytes, pos: int) -> tuple[str, int]:
    """Address at ``pos`` -> (text, position after it)."""
    count, toa = _octets(data, pos, 2)
    octets = (count + 1) // 2
    body = _take(data, pos + 2, octets)
    if (toa >> 4) & 7 == 5:  # alphanumeric
        septets = count * 4 // 7
        return gsm7.decode_septets(gsm7.unpack_septets(body, septets)), pos + 2 + octets
    digits = _unbcd(body, count)
    return ("+" + digits if (toa >> 4) & 7 == 1 else digits), pos + 2 + octets


def encode_smsc(number: str | None) -> bytes:
    """The SMSC part before a TPDU: ``00`` for "the SIM's", else length, TOA, BCD."""
    if not number:
        return b"\x00"
    addr = encode_address(number)
    return bytes((len(addr) - 1,)) + addr[1:]


def decode_smsc(data: bytes) -> tuple[str | None, int]:
    """The SMSC part at the start of ``data`` -> (number or None, TPDU offset)."""
    (length,) = _octets(data, 0, 1)
    if length == 0:
        return None, 1
    toa, body = data[1:2], _take(data, 2, length - 1)
    if not toa:
        raise PduError("PDU ends inside the SMSC address")
    digits = _unbcd(body, 2 * len(body)).rstrip("F")
    return ("+" + digits if (toa[0] >> 4) & 7 == 1 else digits), 1 + length


def encode_timestamp(posix: int, tz_quarters: int = 0) -> bytes:
    """TP-SCTS: local time (UTC + offset) as swapped BCD, then the signed offset."""
    t = _gmtime(posix + tz_quarters * 900)
    digits = "".join(f"{v:02d}" for v in (t[0] % 100, t[1], t[2], t[3], t[4], t[5]))
    tz = abs(tz_quarters)
    tz_octet = (tz % 10) << 4 | (tz // 10) | (0x08 if tz_quarters < 0 else 0)
    return _bcd(digits) + bytes((tz_octet,))


def decode_timestamp(data: bytes) -> tuple[int, int]:
    """TP-SCTS -> (POSIX seconds, offset in quarter hours). Years 00-69 are 20xx."""
    if len(data) != 7:
        raise PduError("short timestamp")
    v = [(b & 0x0F) * 10 + (b >> 4) for b in data[:6]]
    tz = (data[6] & 0x07) * 10 + (data[6] >> 4)
    if data[6] & 0x08:
        tz = -tz
    year = v[0] + (2000 if v[0] < 70 else 1900)
    try:
        local = calendar.timegm((year, v[1], v[2], v[3], v[4], v[5], 0, 0, 0))
    except (ValueError, OverflowError) as exc:  # pragma: no cover - timegm is lenient
        raise PduError("bad timestamp") from exc
    return local - tz * 900, tz


# -- user data ---------------------------------------------------------------------------
def _udh(concat: Concat | None) -> bytes:
    if concat is None:
        return b""
    if concat.wide:
        ie = bytes((0x08, 4, concat.ref >> 8 & 0xFF, concat.ref & 0xFF, concat.total, concat.seq))
    else:
        ie = bytes((0x00, 3, concat.ref & 0xFF, concat.total, concat.seq))
    return bytes((len(ie),)) + ie


def encode_user_data(text: str, alphabet: str, concat: Concat | None, data: bytes = b"") -> bytes:
    """TP-UDL + TP-UD for ``text`` (``data`` for 8-bit), with a concatenation header."""
    header = _udh(concat)
    if alphabet == GSM7:
        septets = gsm7.encode_septets(text)
        head_septets = (len(header) * 8 + 6) // 7
        fill = head_septets * 7 - len(header) * 8
        # the header takes whole octets; the septets start at the next septet boundary
        body = header + gsm7.pack_septets(septets, fill)
        if len(body) > MAX_USER_DATA:
            raise PduError(f"text of {len(septets)} septets does not fit one SMS")
        return bytes((head_septets + len(septets),)) + body
    payload = gsm7.encode_ucs2(text) if alphabet == UCS2 else data
    if len(header) + len(payload) > MAX_USER_DATA:
        raise PduError(f"user data of {len(header) + len(payload)} octets does not fit one SMS")
    return bytes((len(header) + len(payload),)) + header + payload


def decode_user_data(
    data: bytes, pos: int, alphabet: str, udhi: bool
) -> tuple[str, bytes, Concat | None]:
    """TP-UDL + TP-UD at ``pos`` -> (text, raw body after the header, concatenation)."""
    (udl,) = _octets(data, pos, 1)
    ud = data[pos + 1 :]
    header = b""
    if udhi:
        if not ud:
            raise PduError("user data header indicated but absent")
        header = _take(ud, 0, ud[0] + 1)
    concat = _concat_of(header[1:])
    if alphabet == GSM7:
        head_septets = (len(header) * 8 + 6) // 7
        if udl < head_septets or gsm7.packed_length(udl) > len(ud):
            raise PduError("user data shorter than its length")
        fill = head_septets * 7 - len(header) * 8
        septets = gsm7.unpack_septets(ud[len(header) :], udl - head_septets, fill)
        body = ud[len(header) : gsm7.packed_length(udl)]
        return gsm7.decode_septets(septets), body, concat
    if udl > len(ud) or udl < len(header):
        raise PduError("user data shorter than its length")
    body = ud[len(header) : udl]
    text = gsm7.decode_ucs2(body) if alphabet == UCS2 else body.decode("latin-1")
    return text, body, concat


def _concat_of(ies: bytes) -> Concat | None:
    i = 0
    found = None
    while i + 1 < len(ies):
        iei, length = ies[i], ies[i + 1]
        value = ies[i + 2 : i + 2 + length]
        if len(value) != length:
            raise PduError("truncated user data header")
        if iei == 0x00 and length == 3:
            found = Concat(value[0], value[1], value[2])
        elif iei == 0x08 and length == 4:
            found = Concat(value[0] << 8 | value[1], value[2], value[3], wide=True)
        i += 2 + length
    return found


# -- whole PDUs --------------------------------------------------------------------------
def decode_submit(pdu: bytes, with_smsc: bool = True) -> SmsSubmit:
    """An SMS-SUBMIT (SMSC part first when ``with_smsc``)."""
    smsc, pos = decode_smsc(pdu) if with_smsc else (None, 0)
    (first, mr) = _octets(pdu, pos, 2)
    if first & 0x03 != MTI_SUBMIT:
        raise PduError(f"not an SMS-SUBMIT (first octet {first:02X})")
    destination, pos = decode_address(pdu, pos + 2)
    pid, dcs = _octets(pdu, pos, 2)
    pos += 2
    vp_len = {0b00: 0, 0b10: 1, 0b01: 7, 0b11: 7}[(first >> 3) & 3]
    validity = _take(pdu, pos, vp_len)
    pos += vp_len
    alphabet = alphabet_of(dcs)
    text, body, concat = decode_user_data(pdu, pos, alphabet, bool(first & 0x40))
    return SmsSubmit(
        destination=destination,
        text=text,
        smsc=smsc,
        mr=mr,
        pid=pid,
        dcs=dcs,
        validity=validity,
        concat=concat,
        data=body,
        status_report=bool(first & 0x20),
        reject_duplicates=bool(first & 0x04),
        reply_path=bool(first & 0x80),
    )


def encode_submit(
    destination: str,
    text: str,
    *,
    mr: int = 0,
    smsc: str | None = None,
    alphabet: str | None = None,
    validity: int | None = 0xFF,
    concat: Concat | None = None,
    data: bytes = b"",
) -> bytes:
    """An SMS-SUBMIT with its SMSC part (relative validity ``validity``, None for none)."""
    alphabet = alphabet or (GSM7 if gsm7.is_gsm7(text) else UCS2)
    first = MTI_SUBMIT | (0x10 if validity is not None else 0) | (0x40 if concat else 0)
    tpdu = bytes((first, mr & 0xFF)) + encode_address(destination)
    tpdu += bytes((0, dcs_for(alphabet)))
    if validity is not None:
        tpdu += bytes((validity,))
    return encode_smsc(smsc) + tpdu + encode_user_data(text, alphabet, concat, data)


def encode_deliver(
    originator: str,
    text: str,
    timestamp: int,
    *,
    tz_quarters: int = 0,
    smsc: str | None = None,
    alphabet: str | None = None,
    concat: Concat | None = None,
    data: bytes = b"",
    more_messages: bool = False,
) -> bytes:
    """An SMS-DELIVER with its SMSC part; GSM-7 when the text allows, else UCS2."""
    alphabet = alphabet or (GSM7 if gsm7.is_gsm7(text) else UCS2)
    first = MTI_DELIVER | (0 if more_messages else 0x04) | (0x40 if concat else 0)
    tpdu = bytes((first,)) + encode_address(originator) + bytes((0, dcs_for(alphabet)))
    tpdu += encode_timestamp(timestamp, tz_quarters)
    return encode_smsc(smsc) + tpdu + encode_user_data(text, alphabet, concat, data)


def decode_deliver(pdu: bytes, with_smsc: bool = True) -> SmsDeliver:
    """An SMS-DELIVER (SMSC part first when ``with_smsc``)."""
    smsc, pos = decode_smsc(pdu) if with_smsc else (None, 0)
    (first,) = _octets(pdu, pos, 1)
    if first & 0x03 != MTI_DELIVER:
        raise PduError(f"not an SMS-DELIVER (first octet {first:02X})")
    originator, pos = decode_address(pdu, pos + 1)
    pid, dcs = _octets(pdu, pos, 2)
    timestamp, tz = decode_timestamp(_take(pdu, pos + 2, 7))
    text, body, concat = decode_user_data(pdu, pos + 9, alphabet_of(dcs), bool(first & 0x40))
    return SmsDeliver(
        originator=originator,
        text=text,
        timestamp=timestamp,
        tz_quarters=tz,
        smsc=smsc,
        pid=pid,
        dcs=dcs,
        concat=concat,
        data=body,
        more_messages=not first & 0x04,
    )


def tpdu_length(pdu: bytes) -> int:
    """Octets of the TPDU after the SMSC part (the ``<length>`` of ``AT+CMGS``/``+CMGR``)."""
    return len(pdu) - 1 - pdu[0]


def from_hex(text: str) -> bytes:
    try:
        return bytes.fromhex(text)
    except ValueError as exc:
        raise PduError("PDU is not hexadecimal") from exc


# -- helpers -----------------------------------------------------------------------------
def _octets(data: bytes, pos: int, n: int) -> tuple[int, ...]:
    return tuple(_take(data, pos, n))


def _take(data: bytes, pos: int, n: int) -> bytes:
    chunk = data[pos : pos + n]
    if len(chunk) != n:
        raise PduError("PDU ends too early")
    return chunk


def _gmtime(posix: int) -> tuple[int, int, int, int, int, int]:
    t = datetime.fromtimestamp(posix, tz=UTC)
    return t.year, t.month, t.day, t.hour, t.minute, t.second
