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

from sondalog.ala1.modem.atio import (
    At,
    Await,
    CommandMode,
    Recv,
    Request,
    Sleep,
    Write,
    as_reply,
)
from sondalog.ala1.modem.host import Driver

#: §3.4.6.3-4: more than 2 minutes without a command ends the connection.
IDLE_HANGUP = 120.0
#: V.250 guard time around ``+++``.
GUARD = 1.0
#: How often ``+++`` is tried before the modem is set up again.
ESCAPE_TRIES = 2
NO_CARRIER = b"\r\nNO CARRIER\r\n"
SHUTDOWN = b"\r\nSHUTDOWN\r\n"


class EndMarker:
    """Finds the far end's hang-up (one of ``markers``) in data read in pieces, where it may
    come cut across two reads. The bytes after it are kept in :attr:`rest` (gsm.md §7: a
    ``+CMTI`` in the same read as ``NO CARRIER`` is still handled)."""

    def __init__(self, *markers: bytes) -> None:
        self.markers = markers
        self.found: bytes | None = None  # the marker that came
        self.rest = b""  # what came after it
        self._keep = max(len(m) for m in markers) - 1
        self._tail = b""  # the last bytes seen, too few to hold a whole marker

    def cut(self, data: bytes) -> tuple[bytes, bool]:
        """``data`` up to the marker, and whether the marker has come (with these bytes)."""
        seen = self._tail + data
        hits = [(seen.find(m), m) for m in self.markers if m in seen]
        if hits:
            at, marker = min(hits)
            self.found, self.rest = marker, seen[at + len(marker) :]
            return data[: max(at - len(self._tail), 0)], True
        self._tail = seen[-self._keep :]
        return data, False


def leave_data_mode(d: Driver) -> Generator[Request, object, bool]:
    """``+++`` between two guard times: back to command mode (the connection stays);
    whether the modem said so.

    The guard times are the modem's to measure: bytes delayed on the way can make it take
    ``+++`` as data, so it is tried again. A modem that had already left data mode (coverage
    lost: ``NO CARRIER`` the logger did not see) takes ``+++`` as the start of a command
    line; a lone CR ends it with an answer. With no answer at all the mode is unknown: the
    reader stays in data mode (no AT command goes out) and the modem is set up again."""
    for _ in range(ESCAPE_TRIES):
        yield Sleep(GUARD)
        yield Write(b"+++")
        yield CommandMode()
        if as_reply((yield Await(GUARD + 2.0))).final:
            return True
        d.reader.raw = True
    yield CommandMode()
    yield Write(b"\r")
    if as_reply((yield Await(GUARD))).final:
        return True
    d.reader.raw = True
    d.out_of_step("no answer to +++")
    return False


def back_in_command_mode(d: Driver, end: EndMarker) -> None:
    """``NO CARRIER`` came in the data: the modem is in command mode; what followed the
    marker is read as lines (URCs it held during the call)."""
    d.reader.command_mode(end.rest)
    d.take_lines()


def data_session(d: Driver, socket: int | None) -> Generator[Request, object, None]:
    session = d.host.open_session(d.now)
    d.session = session
    last = d.now
    # a call ends with NO CARRIER; a socket with SHUTDOWN, or NO CARRIER when the modem
    # lost its bearer (coverage) and dropped to command mode
    end = EndMarker(NO_CARRIER) if socket is None else EndMarker(SHUTDOWN, NO_CARRIER)
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
    d.listing_due = True  # SMS that came during the session had no notice (gsm.md §7)
    if ended and end.found == NO_CARRIER:
        back_in_command_mode(d, end)
        if socket is not None:
            yield At(f"AT+WIPCLOSE=2,{socket}")
        return
    if (yield from leave_data_mode(d)):
        yield At("ATH" if socket is None else f"AT+WIPCLOSE=2,{socket}")
