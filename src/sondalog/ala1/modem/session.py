"""A command session over a data call or a TCP connection to port 10001 (§3.4.6.3-4).

The far end's bytes go to a private line of the logger, which answers them as it answers a
cable line (echo, ESC, the entry timeout, ``pause``); its answers go back through the driver
(:meth:`~sondalog.ala1.modem.driver.ModemDriver.session_output`). After
:data:`IDLE_HANGUP` seconds without a command (a line end) the logger hangs up: ``+++`` with
its 1 s guard times, then ``ATH`` (a call) or ``AT+WIPCLOSE`` (a socket). The far end hanging
up shows as ``NO CARRIER`` (call) or ``SHUTDOWN`` (socket) in the data stream.
"""

from __future__ import annotations

from collections.abc import Generator
from typing import TYPE_CHECKING

from sondalog.ala1.modem.atio import At, Await, CommandMode, Recv, Request, Sleep, Write

if TYPE_CHECKING:
    from sondalog.ala1.modem.driver import ModemDriver

#: §3.4.6.3-4: more than 2 minutes without a command ends the connection.
IDLE_HANGUP = 120.0
#: V.250 guard time around ``+++``.
GUARD = 1.0
NO_CARRIER = b"\r\nNO CARRIER\r\n"
SHUTDOWN = b"\r\nSHUTDOWN\r\n"


class EndMarker:
    """Finds the far end's hang-up (``marker``) in data read in pieces, where it may come
    cut across two reads."""

    def __init__(self, marker: bytes) -> None:
        self.marker = marker
        self._tail = b""  # the last bytes seen, too few to hold the whole marker

    def cut(self, data: bytes) -> tuple[bytes, bool]:
        """``data`` up to the marker, and whether the marker has come (with these bytes)."""
        seen = self._tail + data
        if self.marker in seen:
            return data[: max(seen.index(self.marker) - len(self._tail), 0)], True
        self._tail = seen[-(len(self.marker) - 1) :]
        return data, False


def leave_data_mode(d: ModemDriver) -> Generator[Request, object, None]:
    """``+++`` between two guard times: back to command mode (the connection stays)."""
    yield Sleep(GUARD)
    yield Write(b"+++")
    yield CommandMode()
    yield Await(GUARD + 2.0)


def data_session(d: ModemDriver, socket: int | None) -> Generator[Request, object, None]:
    marker = NO_CARRIER if socket is None else SHUTDOWN
    session = d.host.open_session(d.now)
    d.session = session
    last = d.now
    end = EndMarker(marker)
    ended = False
    try:
        while True:
            data = yield Recv(last + IDLE_HANGUP)
            data, ended = end.cut(data if isinstance(data, bytes) else b"")
            if data:
                d.host.session_input(session, data, d.now)
                if b"\r" in data or b"\n" in data:
                    last = d.now
            if ended or (not data and d.now >= last + IDLE_HANGUP):
                break
    finally:
        d.session = None
        d.host.close_session(session)
    if ended and socket is None:
        d.reader.command_mode()  # NO CARRIER: the modem is back in command mode
        d.reader.data.clear()
        return
    yield from leave_data_mode(d)
    yield At("ATH" if socket is None else f"AT+WIPCLOSE=2,{socket}")
