"""Serial-line helpers shared by the ALA1 lines and the HCTMPS1 bus ports.

- :class:`PtyLink`: a pseudo-terminal whose slave (``/dev/pts/N``) is reachable through a
  stable symlink, replaced atomically and removed on close, so any terminal program or legacy
  host software can open it like a COM port.
- :func:`host_speed`: the baud rate a host set on a pty's slave, read from the master through
  ``TCGETS2`` (``struct termios2``: ``c_ispeed``/``c_ospeed``), falling back to the ``B*``
  speeds of ``tcgetattr``. On Linux a terminal ioctl on a pty master acts on its slave.
- :func:`garble`: what a module receiving at the wrong baud rate makes of the host's bytes.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import struct
import sys
import termios
import tty
from pathlib import Path

#: ``_IOR('T', 0x2A, struct termios2)``: 44 bytes = 4 flags, c_line, c_cc[19], 2 speeds.
#: This encoding holds for x86, ARM and RISC-V; elsewhere :func:`host_speed` falls back.
TCGETS2 = 0x802C542A
_TERMIOS2 = struct.Struct("=4IB19B2I")

#: ``termios.B*`` constants -> baud rate, for the ``tcgetattr`` fallback.
_B_RATES: dict[int, int] = {
    int(getattr(termios, f"B{rate}")): rate
    for rate in (
        50,
        75,
        110,
        134,
        150,
        200,
        300,
        600,
        1200,
        1800,
        2400,
        4800,
        9600,
        19200,
        38400,
        57600,
        115200,
        230400,
        460800,
        500000,
        576000,
        921600,
    )
    if hasattr(termios, f"B{rate}")
}


def host_speed(fd: int) -> int | None:
    """The output baud rate of the terminal ``fd`` (for a pty master: of its slave).

    ``None`` when it cannot be read (not a terminal).
    """
    if sys.platform.startswith("linux"):
        buf = bytearray(_TERMIOS2.size)
        try:
            fcntl.ioctl(fd, TCGETS2, buf)
        except OSError:
            pass
        else:
            ospeed = _TERMIOS2.unpack(buf)[-1]
            if ospeed:
                return int(ospeed)
    try:
        attrs = termios.tcgetattr(fd)
    except termios.error:
        return None
    return _B_RATES.get(int(attrs[5]))


def serial_8n1() -> dict[str, object]:
    """pyserial settings of an ALA1 line: 8N1, no flow control in the driver (XON/XOFF are
    the module's own, §6.11.1)."""
    import serial  # imported here: only serial ports need pyserial

    return {
        "bytesize": serial.EIGHTBITS,
        "parity": serial.PARITY_NONE,
        "stopbits": serial.STOPBITS_ONE,
        "xonxoff": False,
        "rtscts": False,
    }


def garble(data: bytes, host_baud: int, module_baud: int) -> bytes:
    """The bytes a module at ``module_baud`` receives when the host sends at ``host_baud``.

    Every byte is sampled at the wrong bit times and arrives as some other byte with its top
    bit set (a framing-error character): a deterministic function of the byte and the two
    rates. The result never contains ASCII, so it never holds a command, a line end (CR, LF),
    ESC, BS/DEL or XON/XOFF. The garbage collects as a partial command, cleared by the host's
    next CR at the right rate (the module answers it with the error response), by ESC, or by
    the 60 s entry timeout (§3.4.5).
    """
    if host_baud == module_baud:
        return data
    salt = (host_baud * 31 + module_baud * 17) % 251
    table = bytes(0x80 | ((b * 73 + salt) & 0x7F) for b in range(256))
    return data.translate(table)


class PtyLink:
    """A pseudo-terminal in raw mode whose slave is reachable through the symlink ``link``.

    ``keep_slave``: the server keeps the slave open too, so a host closing it causes no
    hang-up on the master. Without it, the master sees a hang-up (``EIO`` on read,
    ``POLLHUP``) whenever no host has the slave open.
    """

    def __init__(self, link: Path, *, keep_slave: bool = True) -> None:
        self.link = link
        if link.exists() and not link.is_symlink():
            raise FileExistsError(f"{link} exists and is not a symlink")
        self.master, slave = os.openpty()
        try:
            tty.setraw(slave)
            self.device = os.ttyname(slave)
            os.set_blocking(self.master, False)
            tmp = link.with_name(f".{link.name}.{os.getpid()}")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            tmp.symlink_to(self.device)
            tmp.replace(link)  # atomic: the link always points at a live pty
        except BaseException:
            os.close(slave)
            os.close(self.master)
            raise
        self.slave: int | None = slave
        if not keep_slave:
            os.close(slave)
            self.slave = None

    def close(self) -> None:
        """Remove the symlink (if it still points here) and close the pty."""
        with contextlib.suppress(OSError):
            if self.link.is_symlink() and os.readlink(self.link) == self.device:
                self.link.unlink()
        if self.slave is not None:
            os.close(self.slave)
            self.slave = None
        if self.master >= 0:
            os.close(self.master)
            self.master = -1
