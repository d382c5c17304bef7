"""Mail text on the wire (RFC 5321 DATA, RFC 1939 multi-line responses), pure.

Line ends become CRLF (a lone CR or LF counts as one line end) and lines starting with ``.``
get one more ``.``; the body ends with the ``.`` line.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

_LINE_ENDS = re.compile(rb"\r\n|\r|\n")


def crlf(message: bytes) -> bytes:
    """``message`` with CRLF line ends, ending with CRLF (as POP3 carries it)."""
    text = _LINE_ENDS.sub(b"\r\n", message)
    return text if not text or text.endswith(b"\r\n") else text + b"\r\n"


def crlf_lines(message: bytes) -> list[bytes]:
    """The lines of :func:`crlf` ``(message)``, without their line ends."""
    return crlf(message).split(b"\r\n")[:-1]


def byte_stuff(lines: Sequence[bytes]) -> bytes:
    """Multi-line body: dots doubled at line starts, each line ended by CRLF, then ``.``."""
    out = [b"." + ln if ln.startswith(b".") else ln for ln in lines]
    return b"".join(ln + b"\r\n" for ln in out) + b".\r\n"


def dot_stuff(message: bytes) -> bytes:
    """The DATA payload: CRLF line ends, leading dots doubled, the final ``.`` line."""
    return byte_stuff(crlf_lines(message))
