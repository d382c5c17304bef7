"""The ALA1 answer codec of the host side (pure): requests, answers, checks (§3, §8).

Host-side client of an ALA1 logger: send a command line, get a parsed :class:`Response`.

Answers (spec notes §1, §3): a read answers its data lines then ``OK``; a write answers
``OK``; a chained line (§7) answers every data line then one ``OK``; an error answers the
command line as received (after line editing, cut to 120 characters, §3.3.1, §3.4.1) and then
``ERROR``. Every line ends with CR LF.

Header options the client can add and check (§8):

- ``check=True`` puts ``check N`` in front (§8.3.1): N is the sum of the byte values from the
  character after N to the end of the line (``check 890 read date``). A module that gets a
  wrong sum answers nothing, so a failed check surfaces as :class:`NoAnswer`.
- ``sum=True`` (§8.4.2): every answer line carries a 5-digit sum of its byte values
  (``00713,20070618111806``, ``00154,OK``); the client verifies and strips it, or raises
  :class:`SumMismatch`.
- ``crcsum=True`` (§8.4.1): before ``OK`` the module sends ``CRC,LENGTH``, the POSIX
  ``cksum`` of all preceding answer bytes as sent (with CR LF and any ``sum`` prefixes); the
  client verifies and removes that line, or raises :class:`CrcMismatch`.
- ``quiet=True`` (§8.5.3): the module sends no ``OK`` and no error response, so the end of
  the answer cannot be seen. The client returns what arrived once the line has been silent for
  ``quiet_period`` seconds after the command was sent (or after the last byte), with status
  :attr:`Status.SILENT`; a silent module is then a normal answer, not :class:`NoAnswer`.

Without ``quiet``, nothing at all within ``timeout`` raises :class:`NoAnswer`; some bytes but
no final line raises :class:`IncompleteAnswer` (e.g. a ``quiet`` or ``startline``/``endline``
header written by hand in the command text, which the client does not interpret). The timeout
runs from the last byte received: an answer still arriving on a slow line is never finished.

Limitation: a data line that reads exactly like the final line (``read text/OK/``) ends the
answer early; its rest is discarded before the next command is sent.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Sequence
from dataclasses import dataclass

from sondalog.protocol.cksum import cksum

#: §3.4.1: the module keeps at most this many characters of a command line.
MAX_LINE = 120
DEFAULT_TIMEOUT = 5.0
DEFAULT_QUIET_PERIOD = 0.3
_BS, _DEL, _XON, _XOFF = "\x08", "\x7f", "\x11", "\x13"
_SUM_RE = re.compile(r"(\d{5,}),")


class ClientError(Exception):
    """Base class of everything the client raises about an answer."""


class NoAnswer(ClientError):
    """Nothing arrived within the timeout (a failed ``check``, a foreign ``iaddress``, §8)."""


class IncompleteAnswer(ClientError):
    """Some bytes arrived but no final ``OK``/``ERROR`` line within the timeout."""

    def __init__(self, message: str, raw: bytes) -> None:
        super().__init__(message)
        self.raw = raw


class ChecksumError(ClientError):
    """An answer failed its ``sum`` or ``crcsum`` verification (§8.4)."""


class SumMismatch(ChecksumError):
    """A line's ``sum`` prefix does not match its bytes (§8.4.2)."""


class CrcMismatch(ChecksumError):
    """The ``crcsum`` line does not match the answer's bytes (§8.4.1)."""


class CommandFailed(ClientError):
    """The module answered with the error response (§3.3.1)."""


class ConnectionLost(ClientError):
    """The connection closed before the answer was complete."""

    @classmethod
    def during(cls, line: str, got: bytes) -> ConnectionLost:
        """Closed while ``line`` was answered, after ``got``."""
        return cls(f"connection closed during {line!r} (got {got!r})")


class Status(enum.Enum):
    OK = "OK"
    ERROR = "ERROR"
    SILENT = "SILENT"  # quiet: the answer ended by silence (§8.5.3)


@dataclass(frozen=True)
class Response:
    """One parsed answer."""

    command: str
    """The command line as sent (with the headers the client added), without CR."""
    lines: tuple[str, ...]
    """Data lines, without CR LF, ``sum`` prefixes, the ``crcsum`` line and ``OK``/``ERROR``."""
    status: Status
    raw: bytes
    """Every byte received for this command, echo included."""
    echo: str | None = None
    """The echo of a ``+`` command (§3.4.2), as received (with any BS sequences)."""
    crc: tuple[int, int] | None = None
    """The verified ``(CRC, LENGTH)`` of a ``crcsum`` answer (§8.4.1)."""

    @property
    def ok(self) -> bool:
        return self.status is Status.OK

    @property
    def error(self) -> bool:
        return self.status is Status.ERROR

    def raise_for_error(self) -> Response:
        """Raise :class:`CommandFailed` for an error response; return self otherwise."""
        if self.error:
            raise CommandFailed(f"the logger rejected {self.command!r}")
        return self


@dataclass(frozen=True)
class Request:
    """A command line with the header options the client adds and verifies."""

    text: str
    check: bool = False
    sum: bool = False
    crcsum: bool = False
    quiet: bool = False

    def line(self) -> str:
        """The line to send (without its CR); worked out once (a request is sent and its
        answer matched against it)."""
        done: str | None = self.__dict__.get("_line")
        if done is None:
            done = self._line()
            object.__setattr__(self, "_line", done)
        return done

    def _line(self) -> str:
        text = self.text
        if "\r" in text or "\n" in text or "\x1b" in text:
            raise ValueError("a command line may not contain CR, LF or ESC")
        echo = self.text.startswith("+")
        body = self.text[1:] if echo else self.text
        headers = [name for name in ("sum", "crcsum", "quiet") if getattr(self, name)]
        if headers:
            body = " ".join([*headers, body])
        if self.check:
            body = with_check(body)
        return ("+" if echo else "") + body

    @property
    def echo(self) -> bool:
        return self.text.startswith("+")


def with_check(text: str) -> str:
    """Put ``check N`` in front of ``text`` (§8.3.1): ``read date`` -> ``check 890 read date``."""
    rest = " " + text
    return f"check {sum(rest.encode('latin-1'))}{rest}"


def line_sum(text: str) -> int:
    """§8.4.2: the sum of the byte values of an answer line (without CR LF)."""
    return sum(text.encode("latin-1"))


def edited(line: str) -> str:
    """The command line as the module keeps it (§3.4): ``+`` dropped, BS/DEL applied, cut."""
    kept: list[str] = []
    for index, char in enumerate(line):
        if index == 0 and char == "+":
            continue
        if char in (_BS, _DEL):
            if kept:
                kept.pop()
        elif char not in (_XON, _XOFF):
            kept.append(char)
    return "".join(kept)[:MAX_LINE]


def strip_sum(line: str) -> str:
    """Verify and remove the ``sum`` prefix of one line (§8.4.2)."""
    match = _SUM_RE.match(line)
    if match is None:
        raise SumMismatch(f"line without a sum prefix: {line!r}")
    rest = line[match.end() :]
    if int(match.group(1)) != line_sum(rest):
        raise SumMismatch(f"sum {match.group(1)} does not match {line_sum(rest):05d} in {line!r}")
    return rest


def verify_crc(crc_line: str, preceding: bytes) -> tuple[int, int]:
    """Check a ``CRC,LENGTH`` line against the bytes sent before it (§8.4.1)."""
    try:
        crc_text, length_text = crc_line.rsplit(",", 1)
        crc, length = int(crc_text), int(length_text)
    except ValueError:
        raise CrcMismatch(f"not a crcsum line: {crc_line!r}") from None
    expected = (cksum(preceding), len(preceding))
    if (crc, length) != expected:
        raise CrcMismatch(
            f"crcsum {crc},{length} does not match the answer ({expected[0]},{expected[1]})"
        )
    return crc, length


def parse_answer(request: Request, raw_lines: Sequence[bytes]) -> Response | None:
    """A complete :class:`Response` from the lines received so far, or None if more follow.

    ``raw_lines`` are the received lines with their CR LF. Raises :class:`ChecksumError` when
    a complete answer fails its verification.
    """
    sent = request.line()
    echo = None
    body = list(raw_lines)
    if request.echo:
        if not body:
            return None
        echo = body.pop(0).decode("latin-1").rstrip("\r\n")
    texts = [line.decode("latin-1").removesuffix("\n").removesuffix("\r") for line in body]
    raw = b"".join(raw_lines)
    if len(texts) == 2 and texts[1] == "ERROR" and texts[0] == edited(sent):
        return Response(sent, (), Status.ERROR, raw, echo)
    if not texts:
        return None
    last = texts[-1]
    if request.sum:
        if not last.endswith(",OK"):
            return None
        texts = [strip_sum(text) for text in texts]
    elif last != "OK":
        return None
    data = texts[:-1]
    crc = None
    if request.crcsum:
        if not data:
            raise CrcMismatch("the crcsum line is missing")
        crc = verify_crc(data.pop(), b"".join(body[:-2]))
    return Response(sent, tuple(data), Status.OK, raw, echo, crc)


def ends_final(answer: bytes) -> bool:
    """Does ``answer`` end with a line that looks final: ``OK``, ``ERROR`` or a decorated
    ``...,OK`` (``sum``, ``number``; §3.3.1, §8.4.2)?"""
    if not answer.endswith(b"\n"):
        return False
    final = answer.rstrip(b"\r\n").rsplit(b"\n", 1)[-1].rstrip(b"\r")
    return final in (b"OK", b"ERROR") or final.endswith(b",OK")
