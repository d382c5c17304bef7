"""One line of text per chunk the modem's serial line carried, for ``--trace FILE``.

The modem core calls its ``trace`` hook with ``("rx", bytes, now)`` for what the DTE (the
logger) wrote and ``("tx", bytes, now)`` for what the modem answered; :func:`trace_line`
turns that into a readable line the runtime appends to the file, e.g.::

    2025-11-30T01:00:00.000Z  logger>modem  AT+CSQ\\r
    2025-11-30T01:00:00.000Z  modem>logger  \\r\\n+CSQ: 18,0\\r\\n\\r\\nOK\\r\\n
"""

from __future__ import annotations

from datetime import UTC, datetime

_ARROWS = {"rx": "logger>modem", "tx": "modem>logger"}
_NAMES = {0x0D: "\\r", 0x0A: "\\n", 0x1A: "<ctrl-z>", 0x1B: "<esc>", 0x5C: "\\\\"}


def escape(data: bytes) -> str:
    """Printable ASCII as is, CR/LF as ``\\r``/``\\n``, Ctrl-Z and ESC by name, else ``\\xNN``."""
    return "".join(_NAMES.get(b) or (chr(b) if 0x20 <= b < 0x7F else f"\\x{b:02x}") for b in data)


def trace_line(direction: str, data: bytes, now: float) -> str:
    """``<UTC time>  <direction>  <escaped bytes>`` with a final newline."""
    stamp = datetime.fromtimestamp(now, tz=UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
    return f"{stamp}  {_ARROWS.get(direction, direction)}  {escape(data)}\n"
