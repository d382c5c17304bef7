"""Sending an SMS through a modem on a serial line, sans-I/O (issue 21, ``kind = "sms"``,
``via = "modem"``): the text cut to one SMS, the SMS-SUBMIT PDU, and the AT conversation.

The conversation is what gammu does in PDU mode (recipes §5), without its identification
rounds: ``ESC`` (leaves a half-typed SMS) ``AT``, ``ATE0`` (no echo), ``AT+CMGF=0`` (PDU
mode), then per destination ``AT+CMGS=<TPDU octets>``, the prompt ``"> "``, the PDU in hex
and Ctrl-Z, answered ``+CMGS: <mr>`` and ``OK``. ``ERROR``, ``+CMS ERROR`` or ``+CME ERROR``
at any step ends it with :class:`ModemError`. The PDU's SMSC part is ``00`` (the SIM's
SMS centre), its validity relative (``FF``: the longest).

One SMS per notification: a text longer than one SMS (160 GSM-7 septets, or 70 UCS2
characters when it has a character outside the GSM alphabet) is cut and ends with ``...``
(:func:`one_sms`). The whole text stays in the store and on the dashboard; a storm of
alarms must not become a storm of multi-part SMS.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from sondalog.protocol import gsm7

#: Septets (GSM-7) and UTF-16 code units (UCS2) of one SMS without a user data header.
GSM7_LIMIT = gsm7.SMS_SEPTETS
UCS2_LIMIT = gsm7.SMS_UCS2_CHARS
ELLIPSIS = "..."
#: The most the modem may send before a step ends (a bounded read buffer).
MAX_BUFFER = 4096
#: Seconds a command may take; a submission waits for the network.
COMMAND_TIMEOUT = 5.0
SUBMIT_TIMEOUT = 30.0
CTRL_Z = b"\x1a"
ESC = b"\x1b"
_FINAL_ERROR = re.compile(r"(ERROR|\+CMS ERROR: .*|\+CME ERROR: .*|NO CARRIER)")


class ModemError(Exception):
    """The modem refused, answered nonsense, or sent too much."""


def one_sms(text: str) -> tuple[str, bool]:
    """``text`` cut to one SMS (ending ``...`` when cut) and whether it is GSM-7 (else
    UCS2)."""
    if gsm7.is_gsm7(text):
        if gsm7.septet_length(text) <= GSM7_LIMIT:
            return text, True
        out, used = [], 0
        for ch in text:
            need = gsm7.char_septets(ch)
            if used + need > GSM7_LIMIT - len(ELLIPSIS):
                break
            out.append(ch)
            used += need
        return "".join(out) + ELLIPSIS, True
    if len(gsm7.encode_ucs2(text)) // 2 <= UCS2_LIMIT:
        return text, False
    out, used = [], 0
    for ch in text:
        need = len(ch.encode("utf-16-be")) // 2
        if used + need > UCS2_LIMIT - len(ELLIPSIS):
            break
        out.append(ch)
        used += need
    return "".join(out) + ELLIPSIS, False


def _address(number: str) -> bytes:
    """TP-DA: digit count, type of address (0x91 international, 0x81 unknown), BCD."""
    digits = number.removeprefix("+")
    if not digits.isdigit():
        raise ValueError(f"not a phone number: {number!r}")
    padded = digits + ("F" if len(digits) % 2 else "")
    bcd = bytes(int(padded[i + 1], 16) << 4 | int(padded[i]) for i in range(0, len(padded), 2))
    return bytes((len(digits), 0x91 if number.startswith("+") else 0x81)) + bcd


def submit_pdu(number: str, text: str) -> tuple[str, int]:
    """The SMS-SUBMIT for ``text`` (already one SMS, :func:`one_sms`) to ``number``: the hex
    of SMSC part and TPDU, and the TPDU's length in octets (the ``AT+CMGS`` parameter)."""
    if gsm7.is_gsm7(text):
        septets = gsm7.encode_septets(text)
        if len(septets) > GSM7_LIMIT:
            raise ValueError(f"{len(septets)} septets do not fit one SMS")
        dcs, user_data = 0x00, bytes((len(septets),)) + gsm7.pack_septets(septets)
    else:
        payload = gsm7.encode_ucs2(text)
        if len(payload) > 2 * UCS2_LIMIT:
            raise ValueError(f"{len(payload)} octets do not fit one SMS")
        dcs, user_data = 0x08, bytes((len(payload),)) + payload
    # first octet: SMS-SUBMIT (MTI 1) with a relative validity period (VPF 10)
    tpdu = bytes((0x11, 0x00)) + _address(number) + bytes((0x00, dcs, 0xFF)) + user_data
    return "00" + tpdu.hex().upper(), len(tpdu)


@dataclass
class _Step:
    command: bytes
    pdu: bytes = b""  # written after the "> " prompt
    timeout: float = COMMAND_TIMEOUT


@dataclass
class Conversation:
    """The AT conversation that sends ``text`` to ``numbers``. :meth:`start` gives the first
    bytes to write; :meth:`receive` takes what the modem sent and gives what to write next
    (``b""``: nothing yet). :attr:`done` when every SMS is sent; :attr:`references` their
    message references; :attr:`timeout`: seconds the current step may still wait."""

    numbers: tuple[str, ...]
    text: str
    references: list[int] = field(default_factory=list)
    _steps: list[_Step] = field(default_factory=list)
    _buffer: bytes = b""
    _prompted: bool = False

    def start(self) -> bytes:
        body, _ = one_sms(self.text)
        self._steps = [_Step(b"AT\r"), _Step(b"ATE0\r"), _Step(b"AT+CMGF=0\r")]
        for number in self.numbers:
            hex_pdu, length = submit_pdu(number, body)
            command = f"AT+CMGS={length}\r".encode()
            self._steps.append(_Step(command, hex_pdu.encode() + CTRL_Z, SUBMIT_TIMEOUT))
        return ESC + self._steps[0].command

    @property
    def done(self) -> bool:
        return not self._steps

    @property
    def timeout(self) -> float:
        return self._steps[0].timeout if self._steps else 0.0

    @property
    def step(self) -> str:
        """The current command (for messages)."""
        return self._steps[0].command.decode().strip() if self._steps else "done"

    def receive(self, data: bytes) -> bytes:
        """What the modem sent -> what to write now; raises :class:`ModemError`."""
        if not self._steps:
            return b""
        self._buffer += data
        if len(self._buffer) > MAX_BUFFER:
            raise ModemError(f"{self.step}: the modem sent {len(self._buffer)} bytes, no answer")
        step = self._steps[0]
        if step.pdu and not self._prompted:
            lines, _ = _lines(self._buffer)
            self._check_errors(lines)
            at = self._buffer.find(b"> ")
            if at < 0:
                return b""
            self._buffer = self._buffer[at + 2 :]
            self._prompted = True
            return step.pdu
        lines, rest = _lines(self._buffer)
        for i, line in enumerate(lines):
            self._check_errors([line])
            if line == "OK":
                later = lines[i + 1 :]
                self._buffer = b"".join(x.encode("latin-1") + b"\r\n" for x in later) + rest
                self._finish(lines[:i])
                return self._steps[0].command if self._steps else b""
        return b""

    def _finish(self, lines: list[str]) -> None:
        step = self._steps.pop(0)
        if step.pdu:
            ref = next((x for x in lines if x.startswith("+CMGS:")), None)
            if ref is None or not ref[6:].strip().isdigit():
                raise ModemError(f"{step.command.decode().strip()}: OK without +CMGS")
            self.references.append(int(ref[6:]))
            self._prompted = False

    def _check_errors(self, lines: list[str]) -> None:
        for line in lines:
            if _FINAL_ERROR.fullmatch(line):
                raise ModemError(f"{self.step}: {line}")


def _lines(buffer: bytes) -> tuple[list[str], bytes]:
    """Complete lines (without empty ones) and the incomplete rest."""
    parts = re.split(rb"\r\n|\r|\n", buffer)
    rest = parts.pop()
    return [p.decode("latin-1").strip() for p in parts if p.strip()], rest
