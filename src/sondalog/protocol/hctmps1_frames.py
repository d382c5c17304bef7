"""Frames on the HCTMPS1 bus: ``:DST,SRC,BODY|CCCC<CR><LF>`` (hctmps1.md §2).

:func:`encode_frame` builds the bytes of one frame; :class:`FrameDecoder` turns a byte stream
(with noise, collisions and partial reads) into the frames it holds. Bytes before ``:`` are
skipped, and a line that does not parse is searched for a later ``:`` so that a good frame
following noise is still found (resynchronisation). Anything that is not a well-formed frame
with a correct CRC is dropped silently, as the module does (§2).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from sondalog.protocol.modbus_crc import crc16_modbus

#: Broadcast destination (§2).
BROADCAST = "*"

#: Longest line kept while waiting for ``<LF>``; longer garbage is dropped.
MAX_LINE = 512

_ID_RE = re.compile(r"[A-Za-z0-9_-]{1,8}")
_BODY_RE = re.compile(r"[\x20-\x7b\x7d\x7e]+")  # printable ASCII except "|"
_FRAME_RE = re.compile(
    rb":([A-Za-z0-9_*-]{1,8}),([A-Za-z0-9_-]{1,8}),([\x20-\x7b\x7d\x7e]+)\|([0-9A-F]{4})\r\n"
)


def is_valid_id(text: str) -> bool:
    """True if ``text`` is a module ID: 1 to 8 of ``A-Z a-z 0-9 _ -`` (§2)."""
    return _ID_RE.fullmatch(text) is not None


class FrameError(ValueError):
    """A frame cannot be encoded because a field breaks the rules of §2."""


@dataclass(frozen=True, slots=True)
class Frame:
    """One frame: destination, source and body (§2)."""

    dst: str
    src: str
    body: str

    @property
    def command(self) -> str:
        """The part of the body before the first ``.``."""
        return self.body.split(".", 1)[0]

    @property
    def param(self) -> str | None:
        """The part of the body after the first ``.``, or None without a ``.``."""
        parts = self.body.split(".", 1)
        return parts[1] if len(parts) == 2 else None

    @property
    def is_broadcast(self) -> bool:
        return self.dst == BROADCAST

    def encode(self) -> bytes:
        return encode_frame(self.dst, self.src, self.body)


def encode_frame(dst: str, src: str, body: str) -> bytes:
    """The bytes of the frame ``:DST,SRC,BODY|CCCC\\r\\n`` (§2)."""
    if not (dst == BROADCAST or is_valid_id(dst)):
        raise FrameError(f"bad destination ID {dst!r}")
    if not is_valid_id(src):
        raise FrameError(f"bad source ID {src!r}")
    if _BODY_RE.fullmatch(body) is None:
        raise FrameError(f"bad body {body!r}: printable ASCII without '|' required")
    covered = f"{dst},{src},{body}".encode("ascii")
    return b":" + covered + f"|{crc16_modbus(covered):04X}\r\n".encode("ascii")


def parse_frame(line: bytes) -> Frame | None:
    """The frame in ``line`` (``:`` through ``<LF>``), or None if it is not a valid frame."""
    match = _FRAME_RE.fullmatch(line)
    if match is None:
        return None
    dst, src, body, check = match.groups()
    covered = line[1 : match.start(4) - 1]
    if crc16_modbus(covered) != int(check, 16):
        return None
    return Frame(dst.decode("ascii"), src.decode("ascii"), body.decode("ascii"))


class FrameDecoder:
    """Incremental frame decoder with resynchronisation after noise (§2)."""

    def __init__(self) -> None:
        self._buf = bytearray()
        #: Bytes dropped so far: noise before ``:`` and lines that were not valid frames.
        self.rejected = 0

    def feed(self, data: bytes) -> list[Frame]:
        """Add received bytes; return the complete valid frames they finish."""
        frames: list[Frame] = []
        self._buf += data
        while True:
            start = self._buf.find(b":")
            if start < 0:
                self.rejected += len(self._buf)
                self._buf.clear()
                return frames
            if start:
                self.rejected += start
                del self._buf[:start]
            end = self._buf.find(b"\n")
            if end < 0:
                if len(self._buf) > MAX_LINE:
                    self.rejected += 1
                    del self._buf[:1]  # drop this ":"; look for the next one
                    continue
                return frames
            line = bytes(self._buf[: end + 1])
            del self._buf[: end + 1]
            frame = _parse_resync(line)
            if frame is None:
                self.rejected += len(line)
            else:
                frames.append(frame)

    def pending(self) -> int:
        """Bytes held while waiting for the end of a line."""
        return len(self._buf)


def _parse_resync(line: bytes) -> Frame | None:
    """Try ``line`` from each ``:`` in turn: the first valid frame wins."""
    start = 0
    while start >= 0:
        frame = parse_frame(line[start:])
        if frame is not None:
            return frame
        start = line.find(b":", start + 1)
    return None


#: A slot is the time of one frame of this many bytes (§2).
SLOT_BYTES = 80


def slot_time(baud: int) -> float:
    """Seconds of one broadcast reply slot: an 80-byte frame of 10-bit bytes (§2)."""
    return SLOT_BYTES * 10 / baud


#: A module starts its answer this long after the end of a request, seconds (docs/hctmps1.md
#: "Decisions": its firmware needs a moment to switch its RS-485 driver on).
TURNAROUND = 0.002


def inter_frame_gap(baud: int) -> float:
    """Idle line the master leaves after the end of an answer (or of its own frame) before its
    next request: the module turnaround plus 3.5 byte times, so a late answer is never overrun
    (sondalog decision, modelled on Modbus RTU's 3.5 characters)."""
    return TURNAROUND + 3.5 * 10 / baud
