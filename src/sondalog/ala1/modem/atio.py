"""The AT conversation as the driver's jobs see it (gsm.md §2).

A job is a generator: it yields a request (send a command and wait for its final result, wait
for an unsolicited result code, sleep, pass raw bytes in data mode) and is resumed with the
answer. :class:`ModemReader` cuts the modem's output into lines (``CR LF`` framed), sees the
``> `` prompt of ``AT+CMGS`` and, after a ``CONNECT``, passes the bytes raw (data mode).
"""

from __future__ import annotations

import re
from collections.abc import Generator
from dataclasses import dataclass, field

#: Final result codes of a command line (V.250, 27.007, 27.005).
FINALS = ("OK", "ERROR", "+CME ERROR", "+CMS ERROR", "NO CARRIER", "BUSY", "NO ANSWER",
          "NO DIALTONE", "CONNECT")  # fmt: skip
#: Unsolicited result codes the driver acts on.
URCS = ("+CMTI:", "RING", "+CRING:", "+CLIP:", "+CUSD:", "+WIPREADY:", "+WIPERROR:",
        "+WIPACCEPT:", "+WIPPEERCLOSE:", "+WIPDATA:")  # fmt: skip
CTRL_Z = b"\x1a"
#: What ends ``ATA`` and ``AT+WIPDATA``: any other final is a late answer (gsm.md §7).
CONNECT_FINALS = ("CONNECT", "NO CARRIER", "ERROR", "+CME ERROR", "BUSY", "NO ANSWER")
#: Bounds on what the modem's side can make the driver hold (DESIGN.md point 8): a line
#: without its end, data-mode bytes nobody takes.
MAX_LINE = 4096
MAX_DATA = 16384
#: At most this many unsolicited result codes wait (a flood from the modem side); a ``+CMTI``
#: dropped there is found by the next listing of the store.
MAX_URCS = 64
#: A modem's output on a line that works as ``local``: a result code framed by CR LF.
MODEM_OUTPUT = re.compile(
    rb"\r\n(?:OK|ERROR|RING|NO CARRIER|CONNECT|BUSY|NO ANSWER|\+C[A-Z]{2,5}:|\+WIP[A-Z]+:)"
)


@dataclass(frozen=True)
class Reply:
    """A command's final result (``""``: no answer in time) and its information lines."""

    final: str
    lines: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return self.final == "OK"

    def info(self, prefix: str) -> str | None:
        return next((ln for ln in self.lines if ln.startswith(prefix)), None)


@dataclass
class PendingReply:
    """A command's answer on its way back (gsm.md §4, §7): by ``sms`` to the sender, or by
    ``email`` (an SMS return address, an e-mail command). It is kept until it went out:
    a failed try is tried again later (:attr:`next_try`, and at once when registration is
    regained), at most :data:`REPLY_TRIES` times within :data:`REPLY_MAX_AGE` seconds.
    ``parts_sent``: the SMS of a long reply already sent (a retry goes on from there)."""

    kind: str
    address: str
    body: str
    first: float
    tries: int = 0
    next_try: float = 0.0
    parts_sent: int = 0


#: gsm.md §7: a reply that still fails after this many tries, or this long, is dropped.
REPLY_TRIES = 12
REPLY_MAX_AGE = 6 * 3600.0
#: The wait after the n-th failed try: 30 s doubling, at most 5 minutes.
REPLY_BACKOFF = (30.0, 300.0)


def reply_backoff(tries: int) -> float:
    first, most = REPLY_BACKOFF
    return float(min(first * 2 ** max(tries - 1, 0), most))


@dataclass(frozen=True)
class At:
    """Send ``AT...`` + CR; the answer is a :class:`Reply` (``prompt``: ``> `` ends it).

    ``finals``: the final result codes this command can end with (``ATA``: ``CONNECT``, ``NO
    CARRIER``...); any other final is a late answer to an earlier command and is passed over
    (gsm.md §7). Empty: any final ends it."""

    line: str
    timeout: float = 10.0
    prompt: bool = False
    finals: tuple[str, ...] = ()


@dataclass(frozen=True)
class Send:
    """Send raw bytes (SMS text and Ctrl-Z), then wait for the final result."""

    data: bytes
    timeout: float = 60.0


@dataclass(frozen=True)
class Await:
    """Wait for a final result without sending (after ``+++``)."""

    timeout: float = 3.0


@dataclass(frozen=True)
class Urc:
    """Wait for an unsolicited line starting with one of ``prefixes``; the line or None."""

    prefixes: tuple[str, ...]
    timeout: float = 30.0


@dataclass(frozen=True)
class Sleep:
    seconds: float


@dataclass(frozen=True)
class Write:
    """Bytes to the modem now (data mode, ``+++``); resumes at once."""

    data: bytes


@dataclass(frozen=True)
class Recv:
    """Data-mode bytes: resumes with what arrived (``b""`` once ``until`` passed)."""

    until: float | None


@dataclass(frozen=True)
class CommandMode:
    """Data mode is over (``+++`` sent): read lines again."""


Request = At | Send | Await | Urc | Sleep | Write | Recv | CommandMode
Job = Generator[Request, object, None]


def as_reply(value: object) -> Reply:
    """The answer to an :class:`At` or :class:`Send` (anything else: no answer in time)."""
    return value if isinstance(value, Reply) else Reply("")


def at(line: str, timeout: float = 10.0) -> Generator[At, object, Reply]:
    return as_reply((yield At(line, timeout)))


@dataclass
class ModemReader:
    """The modem's output cut into lines, the prompt, and raw data in data mode."""

    buffer: bytearray = field(default_factory=bytearray)
    raw: bool = False
    data: bytearray = field(default_factory=bytearray)
    #: The next line is an SMS's text (after a ``+CMGR:``/``+CMGL:`` header): kept even
    #: when empty (a text of one LF), else the listing's ``OK`` would be taken for it.
    body: bool = False

    def feed(self, chunk: bytes) -> list[str]:
        """Lines completed by ``chunk`` (a prompt is the line ``"> "``)."""
        if self.raw:
            self.data += chunk
            if len(self.data) > MAX_DATA:  # nobody reads them: keep the newest, bounded
                del self.data[:-MAX_DATA]
            return []
        self.buffer += chunk
        lines: list[str] = []
        while True:
            if self.buffer.startswith(b"> "):
                del self.buffer[:2]
                lines.append("> ")
                continue
            end = self.buffer.find(b"\n")
            if end < 0:
                if len(self.buffer) > MAX_LINE:  # no line is that long: noise on the line
                    self.buffer.clear()
                return lines
            line = bytes(self.buffer[:end]).strip(b"\r").decode("latin-1")
            del self.buffer[: end + 1]
            if line or self.body:
                self.body = line.startswith(("+CMGR:", "+CMGL:")) and not self.body
                lines.append(line)
                if line.startswith("CONNECT"):  # data mode from the next byte on
                    self.raw = True
                    self.data += self.buffer
                    self.buffer.clear()
                    return lines

    def take_data(self) -> bytes:
        out = bytes(self.data)
        self.data.clear()
        return out

    def command_mode(self, rest: bytes | None = None) -> None:
        """Data mode is over: read lines again, from ``rest`` (the bytes after the end
        marker) when given, else from the data nobody took."""
        self.raw = False
        self.buffer += self.data if rest is None else rest
        self.data.clear()


def is_final(line: str) -> bool:
    return line.startswith(FINALS)


def is_urc(line: str) -> bool:
    """A URC; ``+CREG: <stat>`` (no comma) is the registration URC of ``AT+CREG=1``."""
    return line.startswith(URCS) or (line.startswith("+CREG:") and "," not in line)
