"""A pseudo-terminal line of a device (``logger serve --pty PATH``, ``bus serve --pty PATH``).

The pty's slave is reachable through the stable symlink PATH, so a terminal program or legacy
host software opens it like a COM port. The line is paced (§6.11.2: output at ``com speed``,
10 bit times a byte; the pacing is the core's, this adapter writes what it gets).

Connection: by default the server does not keep the slave open, so the master sees a hang-up
whenever no host has it open. A host opening the slave connects a new line (its own line
state); closing it disconnects that line, which releases message blocking (§6.14.9.2). While
hung up the master is polled every :data:`HANGUP_POLL` seconds for a new host. With
``keep_slave`` (a bus, where a host closing its port changes nothing) the line stays attached.

Baud rate: a pty carries bytes at any rate, so the host's setting is read from the slave
(``TCGETS2``) whenever bytes arrive. When it differs from the device's line speed the device
receives garbage, as on a real line (:func:`~sondalog.io.serial_ports.garble`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import select
from pathlib import Path

from sondalog.io.host import DeviceHost
from sondalog.io.serial_ports import PtyLink, garble, host_speed

log = logging.getLogger(__name__)

#: How often a hung-up pty is checked for a host opening it.
HANGUP_POLL = 0.02
#: Output a host does not read is kept up to this size, then dropped (nobody listening).
MAX_BACKLOG = 1024 * 1024


class PtyLine:
    """One pty attached to a :class:`DeviceHost` as a paced line."""

    def __init__(self, host: DeviceHost, link: Path, *, keep_slave: bool = False) -> None:
        self._host = host
        self._pty = PtyLink(link, keep_slave=keep_slave)
        self._loop = asyncio.get_running_loop()
        self._line: int | None = None
        self._backlog = bytearray()
        self._watch_handle: asyncio.TimerHandle | None = None
        self._closed = False
        self._watch()

    @property
    def link(self) -> Path:
        return self._pty.link

    @property
    def device(self) -> str:
        return self._pty.device

    @property
    def connected(self) -> bool:
        return self._line is not None

    # -- connection --------------------------------------------------------------------------
    def _hung_up(self) -> bool:
        poller = select.poll()
        poller.register(self._pty.master, select.POLLIN)
        return any(events & select.POLLHUP for _, events in poller.poll(0))

    def _watch(self) -> None:
        self._watch_handle = None
        if self._closed:
            return
        if self._hung_up():
            self._watch_handle = self._loop.call_later(HANGUP_POLL, self._watch)
            return
        self._line = self._host.attach(self._send, paced=True)
        log.info("line %d: host opened %s (%s)", self._line, self.link, self.device)
        self._loop.add_reader(self._pty.master, self._readable)

    def _hang_up(self) -> None:
        """The host closed the slave: the line disconnects until it is opened again."""
        self._loop.remove_reader(self._pty.master)
        self._loop.remove_writer(self._pty.master)
        self._backlog.clear()
        if self._line is not None:
            log.info("line %d: host closed %s", self._line, self.link)
            self._host.detach(self._line)
            self._line = None
        if not self._closed:
            self._watch_handle = self._loop.call_later(HANGUP_POLL, self._watch)

    # -- input -------------------------------------------------------------------------------
    def _readable(self) -> None:
        try:
            data = os.read(self._pty.master, 4096)
        except BlockingIOError:
            return
        except OSError:  # EIO: no host has the slave open any more
            self._hang_up()
            return
        if not data:
            self._hang_up()
            return
        if self._line is None:
            return
        theirs = host_speed(self._pty.master)
        ours = self._host.device.line_speed()
        if theirs is not None and theirs != ours:
            log.debug("line %d: host sends at %d baud, module at %d", self._line, theirs, ours)
            data = garble(data, theirs, ours)
        self._host.feed(self._line, data)

    # -- output ------------------------------------------------------------------------------
    def _send(self, data: bytes) -> None:
        if self._line is None:
            return
        if self._backlog:
            self._queue(data)
            return
        try:
            written = os.write(self._pty.master, data)
        except BlockingIOError:
            written = 0
        except OSError as exc:
            log.info("line %d: cannot write to %s: %s", self._line, self.device, exc)
            return
        if written < len(data):
            self._queue(data[written:])
            self._loop.add_writer(self._pty.master, self._writable)

    def _queue(self, data: bytes) -> None:
        room = MAX_BACKLOG - len(self._backlog)
        if room < len(data):
            log.debug("line %s: nobody reads, %d bytes dropped", self._line, len(data) - room)
        self._backlog += data[: max(room, 0)]

    def _writable(self) -> None:
        try:
            written = os.write(self._pty.master, self._backlog)
        except BlockingIOError:
            return
        except OSError:
            written = len(self._backlog)
        del self._backlog[:written]
        if not self._backlog:
            self._loop.remove_writer(self._pty.master)

    def close(self) -> None:
        """Disconnect the line, remove the symlink and close the pty."""
        self._closed = True
        if self._watch_handle is not None:
            self._watch_handle.cancel()
        with contextlib.suppress(ValueError, RuntimeError):
            self._hang_up()
        self._pty.close()
