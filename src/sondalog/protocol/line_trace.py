"""The line trace: what a host and a device said on one line, one text line per chunk.

``sondalog term --trace FILE`` (and :class:`sondalog.client.trace.TracedEndpoint` for any host
tool) writes it; ``sondalog logger replay FILE`` serves it back (:mod:`sondalog.protocol.replay`,
docs/testing.md "Replay"). The format, kept readable so a captured session can be read, cut
and reviewed by hand::

    # sondalog line trace 1: tcp://127.0.0.1:10001
    2026-12-01T22:10:00.123Z  host>logger  read i version\\r
    2026-12-01T22:10:00.131Z  logger>host  2.10\\r\\nOK\\r\\n

- a line starting with ``#`` is a comment, an empty line is skipped;
- otherwise: a UTC time stamp, two spaces, the direction, two spaces, the bytes;
- the direction is ``host>logger`` (bytes the host sent) or ``logger>host`` (bytes the device
  answered). The GSM modem trace of ``sondalog serve --trace`` (``logger>modem``,
  ``modem>logger``, :mod:`sondalog.gsm.trace`) is read as well: there the modem is the device;
- the bytes: printable ASCII as is, CR and LF as ``\\r`` and ``\\n``, a backslash as ``\\\\``,
  any other byte (and a space ending the chunk, which editors strip) as ``\\xNN``. ``<ctrl-z>``
  and ``<esc>`` of the modem trace are read as 0x1A and 0x1B.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime

#: First line of a trace file written by sondalog (the 1 is the format's version).
HEADER = "# sondalog line trace 1"
#: Directions: True for bytes the host sent to the device, False for the device's answer.
TO_DEVICE = {"host>logger": True, "logger>modem": True}
FROM_DEVICE = {"logger>host": False, "modem>logger": False}
_DIRECTIONS = {**TO_DEVICE, **FROM_DEVICE}
#: A trace holds at most this many bytes of traffic (a bound on what a file can make us hold).
MAX_BYTES = 64 * 1024 * 1024

_NAMES = {0x0D: "\\r", 0x0A: "\\n", 0x5C: "\\\\"}
_TOKEN = re.compile(r"\\x[0-9a-fA-F]{2}|\\r|\\n|\\\\|<ctrl-z>|<esc>|\\|[^\\<]+|<")
_UNESCAPE = {"\\r": b"\r", "\\n": b"\n", "\\\\": b"\\", "<ctrl-z>": b"\x1a", "<esc>": b"\x1b"}


class TraceError(ValueError):
    """A trace file that cannot be read: the message names the file and line."""


@dataclass(frozen=True, slots=True)
class Chunk:
    """Bytes one side wrote at one time."""

    to_device: bool
    data: bytes
    at: float = 0.0


def escape(data: bytes) -> str:
    """The bytes as the trace writes them (see the module docstring)."""
    text = "".join(_NAMES.get(b) or (chr(b) if 0x20 <= b < 0x7F else f"\\x{b:02x}") for b in data)
    if text.endswith(" "):
        stripped = text.rstrip(" ")
        text = stripped + "\\x20" * (len(text) - len(stripped))
    return text


def unescape(text: str) -> bytes:
    """The inverse of :func:`escape`; raises ``ValueError`` for a lone backslash."""
    out = bytearray()
    for match in _TOKEN.finditer(text):
        token = match.group()
        if token in _UNESCAPE:
            out += _UNESCAPE[token]
        elif token.startswith("\\x"):
            out.append(int(token[2:], 16))
        elif token == "\\":
            raise ValueError(f"a lone backslash at column {match.start() + 1}")
        else:
            out += token.encode("latin-1", "replace")
    return bytes(out)


def stamp(now: float) -> str:
    """``now`` (seconds since the epoch) as the trace's UTC time stamp, in milliseconds."""
    return datetime.fromtimestamp(now, tz=UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def trace_line(to_device: bool, data: bytes, now: float, device: str = "logger") -> str:
    """One line of the trace for ``data`` (with its newline)."""
    direction = f"host>{device}" if to_device else f"{device}>host"
    return f"{stamp(now)}  {direction}  {escape(data)}\n"


def _parse_stamp(text: str) -> float:
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=UTC).timestamp()


def parse_trace(lines: Iterable[str], name: str = "trace") -> list[Chunk]:
    """The chunks of a trace; raises :class:`TraceError` naming ``name`` and the line."""
    chunks: list[Chunk] = []
    total = 0
    for number, raw in enumerate(lines, 1):
        line = raw.rstrip("\r\n")
        if not line.strip() or line.startswith("#"):
            continue
        when, _, rest = line.partition("  ")
        direction, _, data = rest.partition("  ")
        where = f"{name}:{number}"
        if direction not in _DIRECTIONS:
            raise TraceError(
                f"{where}: expected 'TIME  DIRECTION  BYTES' with DIRECTION one of "
                f"{', '.join(_DIRECTIONS)}; got {line[:60]!r}"
            )
        try:
            at = _parse_stamp(when)
        except ValueError:
            raise TraceError(
                f"{where}: bad time stamp {when[:40]!r} (expected 2026-12-01T22:10:00.123Z)"
            ) from None
        try:
            payload = unescape(data)
        except ValueError as exc:
            raise TraceError(f"{where}: {exc}") from None
        total += len(payload)
        if total > MAX_BYTES:
            raise TraceError(f"{where}: the trace holds more than {MAX_BYTES} bytes")
        if payload:
            chunks.append(Chunk(_DIRECTIONS[direction], payload, at))
    return chunks
