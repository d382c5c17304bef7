"""The ALA1 engine: a pure, sans-I/O core (DESIGN.md point 1).

Transports feed it received bytes with the current clock time and send what it returns; they
wake it at :meth:`Engine.next_deadline` by calling :meth:`Engine.advance`. Each line (a TCP
connection, a pty, a serial port) has its own line state (§3.4 and spec notes §1): echo,
partial command, entry timeout, a command waiting for its ``pause`` or its sensors, and its
transmitter (:class:`~sondalog.ala1.pacing.Pacer`: baud-rate pacing, XON/XOFF). Commands run
one at a time, and each answer goes to the line that sent the command.
"""

from __future__ import annotations

import logging
import re
from typing import TYPE_CHECKING

from sondalog.ala1 import transfers
from sondalog.ala1.hardware import Hardware
from sondalog.ala1.headers import MAX_LINE
from sondalog.ala1.interpreter import Answer, Interpreter
from sondalog.ala1.lines import Line as _Line
from sondalog.ala1.messages import Messages
from sondalog.ala1.model import Identity
from sondalog.ala1.outbox import Outbox
from sondalog.ala1.pacing import Pacer
from sondalog.ala1.state import ModuleState, NeedWait, NvStore
from sondalog.protocol.device import Event, LineSend

if TYPE_CHECKING:  # (no circle: the link knows the engine by its LinkEngine protocol)
    from sondalog.ala1.modem.link import ModemLink

log = logging.getLogger(__name__)

CR, LF, BS, DEL, ESC, XON, XOFF = 0x0D, 0x0A, 0x08, 0x7F, 0x1B, 0x11, 0x13
#: §3.4.5: a command must be entered within one minute of its first character.
ENTRY_TIMEOUT = 60.0
BREAK = b"BREAK\r\n"
#: A whole command line as a program sends it: no echo, no editing key, no flow control
#: byte, at most 120 characters, then CR (and LF): :meth:`Engine._plain` (issue 11).
_PLAIN = re.compile(rb"[^+\r\n\x08\x7f\x1b\x11\x13][^\r\n\x08\x7f\x1b\x11\x13]{0,119}\r\n?")
#: One whole line inside received data after flow control, as :meth:`Engine._feed`'s loop
#: would take it (no ``+``, no editing key; CR, and an LF after it, which ends an empty line).
_WHOLE = re.compile(rb"[^+\r\n\x08\x7f\x1b][^\r\n\x08\x7f\x1b]{0,%d}\r\n?" % (MAX_LINE - 1))


class Engine:
    """One ALA1 module: its state and the lines attached to it."""

    def __init__(
        self,
        identity: Identity,
        store: NvStore,
        now: float,
        hardware: Hardware | None = None,
        *,
        line_time_scale: float = 1.0,
    ) -> None:
        """``line_time_scale``: how many clock seconds pass in one second of line time.

        With ``--speed S`` the clock runs S times faster than real time, but what happens on
        a line (byte pacing, the entry timeout, XON/XOFF, ``pause``, XMODEM) follows real
        time: line durations are S clock seconds long (docs/decisions.md "Time base")."""
        self.scale = line_time_scale
        self.identity = identity
        self.state = ModuleState(identity, store, now, hardware)
        self.interpreter = Interpreter(self.state)
        #: What the module sends by itself (§6.14); the modem driver takes its sms/email
        #: sendings from here, the cable line its local ones (:meth:`_messages`).
        self.outbox = Outbox()
        self.messages = Messages(
            self.state, self.interpreter, self.outbox, now, line_time_scale=line_time_scale
        )
        self._lines: dict[int, _Line] = {}
        self._busy: dict[int, _Line] = {}  # lines with output, a timer or a transfer (#11)
        self._blocking: set[int] = set()  # lines whose blocks_messages is set
        self._next_id = 1
        self.modem: ModemLink | None = None  # the com line drives a modem (ala1/modem/)

    # -- lines -----------------------------------------------------------------------------
    def open_line(self, *, paced: bool = False) -> int:
        """Attach a new line (a connection); returns its id.

        ``paced``: output leaves at ``com speed`` (10 bit times a byte), as on a serial line.
        """
        line_id = self._next_id
        self._next_id += 1
        self._lines[line_id] = _Line(Pacer(paced), ident=line_id)
        return line_id

    def attach_modem(self, now: float, outbox: Outbox | None = None) -> int:
        """The com line is the modem's line (``com device wavecom4x``, §6.11.5.2): its bytes
        go through the modem driver (:mod:`sondalog.ala1.modem`); returns the line id."""
        from sondalog.ala1.modem.link import ModemLink  # loaded by a modem line only (start-up)

        line_id = self.open_line(paced=True)  # 8N1 at com speed to the modem (§6.11.2)
        self.modem = ModemLink(self, line_id, now, outbox or self.outbox)
        self.modem.on_ring = self.messages.trigger  # §6.10.2.3-4: ringvoice/ringdata M
        return line_id

    def execute(self, text: str, now: float, paused: bool = False) -> bytes | float:
        """Run ``text`` as a line would; its answer, or seconds to wait (modem/link.py)."""
        from sondalog.ala1.modem.link import execute  # (start-up time, as attach_modem)

        return execute(self, text, now, paused)

    def write_line(self, line_id: int, data: bytes, now: float) -> None:
        self.send(self._lines[line_id], data, now)

    def take_line_output(self, line_id: int, now: float) -> bytes:
        line = self._lines.get(line_id)
        return b"" if line is None else b"".join(d for d, _ in line.pacer.take(now / self.scale))

    def close_line(self, line_id: int) -> None:
        """The line is gone (disconnected): it no longer blocks messages (§6.14.9.2)."""
        self._lines.pop(line_id, None)
        self._busy.pop(line_id, None)
        self._blocking.discard(line_id)

    @property
    def messages_blocked(self) -> bool:
        """§6.14.9.2: a line that sent a command holds messages back until it disconnects
        or sends ``write com close``."""
        return bool(self._blocking)

    @property
    def modem_busy(self) -> bool:
        """§6.14.9.1: set by the modem driver while the modem is in use; messages wait."""
        return self.outbox.modem_busy

    @modem_busy.setter
    def modem_busy(self, busy: bool) -> None:
        self.outbox.modem_busy = busy

    def _sync_modem(self) -> None:
        """§6.14.9.1: messages wait while the modem is in use; with no modem answering the
        com line works as local (gsm notes §3)."""
        if self.modem is not None:
            self.outbox.modem_busy = self.modem.busy
            self.state.modem_absent = self.modem.driver.present is False

    def _modem_owns_line(self) -> None:
        """gsm notes §7: while the driver has the modem line, no text typed on it while it
        worked as local is answered there (no BREAK, no echo into the modem)."""
        if self.modem is not None and not self.modem.driver.local:
            line = self._lines[self.modem.line]
            if line.started is not None or line.pending is not None:
                self._reset(line)
                line.pending = None
                line.take_backlog()

    def _local_ready(self) -> bool:
        """A cable line is attached and none blocks messages (§6.14.9.2)."""
        return bool(self._lines) and not self._blocking

    def _messages(self, now: float) -> None:
        """§6.14: messages that may go now; with ``com device local`` this is their carrier:
        the body goes on every line as plain text, and that counts as delivered."""
        if self.modem is not None:
            self._sync_modem()
        ready = self._local_ready()
        self.messages.step(now, local_ready=ready)
        while ready and (outgoing := self.outbox.take("local")) is not None:
            data = outgoing.body.encode("latin-1", "replace")
            for line in self._lines.values():
                self.send(line, data, now)
            self.outbox.done(outgoing.ident, True)

    def input_room(self, line_id: int) -> int | None:
        """Bytes the line takes now without losing any (None: no bound; issue 20)."""
        line = self._lines.get(line_id)
        return None if line is None else line.room()

    def output_pending(self, line_id: int) -> bool:
        """True while a line still has bytes waiting to be sent (paced or stopped by XOFF)."""
        line = self._lines.get(line_id)
        return line is not None and line.pacer.pending() > 0

    @property
    def com_speed(self) -> int:
        return int(self.state.setting("com speed"))

    def line_speed(self) -> int:
        """§6.11.2: every line of the module runs at ``com speed``."""
        return self.com_speed

    def handle(self, event: Event, now: float) -> list[LineSend]:
        """Typed events (messages and the modem add theirs); none are known yet."""
        log.warning("event %r not handled by the ALA1 engine", event)
        return []

    # -- input -----------------------------------------------------------------------------
    def receive(self, line_id: int, data: bytes, now: float) -> list[LineSend]:
        """Bytes received on a line at time ``now``; returns what to send now."""
        if self.modem is not None and line_id == self.modem.line:
            self.state.run_sampling(now)
            if self.modem.receive(data, now):
                self._modem_owns_line()
                return self._drain(now)
        line = self._lines[line_id]
        if (
            line.started is None
            and line.pending is None
            and line.transfer is None
            and line.pacer.quiet()
            and _PLAIN.fullmatch(data) is not None
        ):
            return self._plain(line_id, line, data.rstrip(b"\n")[:-1].decode("latin-1"), now)
        self.accept(line_id, data, now)
        return self._drain(now)

    def _plain(self, line_id: int, line: _Line, text: str, now: float) -> list[LineSend]:
        """One whole command line on a quiet line without pacing (issue 11): what
        :meth:`accept` and :meth:`_drain` do with it, without the line discipline's edits
        and the transmitter's queue (nothing waits in it)."""
        self.state.run_sampling(now)
        out: list[LineSend] = []
        answer, speed = self._command(line_id, line, text, False, now)
        if answer is not None and answer.transfer is not None:
            self._deliver(line, text, answer, now, speed)  # XMODEM goes through the queue
        elif answer is not None and answer.data:
            out.append(LineSend(line_id, answer.data, answer.baud or speed))
        self._messages(now)
        if self._busy:
            out += self._drain(now)
        return out

    def accept(self, line_id: int, data: bytes, now: float) -> None:
        """Bytes received on a line, through the line discipline (nothing drained)."""
        line = self._lines[line_id]
        self._busy[line_id] = line
        self.state.run_sampling(now)
        self._expire(line_id, line, now)
        if line.transfer is not None:
            data = transfers.take_input(self, line, data, now)
        if not data:
            pass
        elif line.pending is not None:
            line.hold(self._flow_control(line, data, now))
        else:
            self._feed(line_id, line, data, now)
        self._messages(now)

    def advance(self, now: float) -> list[LineSend]:
        """Run what is due at ``now``: samples, waiting commands, timeouts, paced output."""
        self.state.run_sampling(now)
        self._modem_owns_line()
        for line_id, line in list(self._busy.items()):
            self._expire(line_id, line, now)
        self._messages(now)  # first: a sending it queues is the modem driver's to start now
        if self.modem is not None:
            self.modem.advance(now)
        return self._drain(now)

    def next_deadline(self) -> float | None:
        """Clock time at which :meth:`advance` must be called next (None: only on input)."""
        sampling = self.state.next_event_host()
        deadlines = [] if sampling is None else [sampling]
        if self.modem is not None:
            if (modem := self.modem.next_deadline()) is not None:
                deadlines.append(modem)
            self._sync_modem()  # a modem no longer busy wakes the messages that waited for it
        message = self.messages.next_deadline(local_ready=self._local_ready())
        if message is not None:
            deadlines.append(message)
        idle: list[int] = []
        for line in self._busy.values():
            if line.idle():
                idle.append(line.ident)
            else:
                deadlines += line.deadlines(ENTRY_TIMEOUT * self.scale, self.scale)
        for line_id in idle:
            del self._busy[line_id]
        return min(deadlines, default=None)

    # -- internals ---------------------------------------------------------------------------
    def _drain(self, now: float) -> list[LineSend]:
        if self.modem is not None:
            self.modem.pump(now)
        out = []
        for line_id, line in self._busy.items():
            if line.pacer.idle():
                continue
            for data, baud in line.pacer.take(now / self.scale):
                out.append(LineSend(line_id, data, baud))
        return out

    def send(self, line: _Line, data: bytes, now: float, baud: int | None = None) -> None:
        """Queue ``data`` on ``line``'s transmitter at ``baud`` (default ``com speed``)."""
        self._busy[line.ident] = line
        line.pacer.push(data, baud or self.com_speed, now / self.scale)

    def _flow_control(self, line: _Line, data: bytes, now: float) -> bytes:
        """§6.11.1: XON/XOFF steer the line's output; they are never command text."""
        if XON not in data and XOFF not in data:
            return data
        for byte in data:
            if byte == XOFF:
                line.pacer.xoff(now / self.scale)
            elif byte == XON:
                line.pacer.xon(now / self.scale)
        return data.replace(bytes([XON]), b"").replace(bytes([XOFF]), b"")

    def _expire(self, line_id: int, line: _Line, now: float) -> None:
        if line.transfer is not None:
            transfers.expire(self, line, now)
        if line.pending is not None and now >= line.run_at:
            command, line.pending = line.pending, None
            answer = self._answer(line_id, line, command, now, line.speed, paused=True)
            if answer is not None:
                self._deliver(line, command, answer, now, line.speed)
            if line.pending is None:
                backlog, overrun = line.take_backlog()
                if backlog:
                    self._feed(line_id, line, backlog, now)
                if overrun:
                    line.lost_after_backlog(now)
        if line.started is not None and now - line.started >= ENTRY_TIMEOUT * self.scale:
            self._break(line, now)

    def _break(self, line: _Line, now: float) -> None:
        """§3.4.3, §3.4.5: discard the partial command; ``BREAK`` when echo is on."""
        if line.echo:
            self.send(line, b"\r\n" + BREAK, now)
        self._reset(line)

    @staticmethod
    def _reset(line: _Line) -> None:
        line.buffer.clear()
        line.echo = False
        line.started = None
        line.overflow = False

    def _feed(self, line_id: int, line: _Line, data: bytes, now: float) -> None:
        """The line discipline (§3.4) over received bytes, a line at a time: a whole line
        without echo or editing keys at once (issues 11, 24: a client's chained reads come as
        many lines together), any other byte by byte (:meth:`_bytes`)."""
        data = self._flow_control(line, data, now)
        at = 0
        while at < len(data):
            if not line.buffer and line.started is None and (found := _WHOLE.match(data, at)):
                at = found.end()
                text = data[found.start() : at].rstrip(b"\n")[:-1].decode("latin-1")
                self._complete(line_id, line, text, False, now)
            else:
                at = self._bytes(line_id, line, data, at, now)
            if line.pending is not None:
                line.hold(data[at:])
                return
            if line.transfer is not None:  # the rest belongs to the XMODEM transfer
                rest = transfers.take_input(self, line, data[at:], now)
                if rest:
                    self._feed(line_id, line, rest, now)
                return

    def _bytes(self, line_id: int, line: _Line, data: bytes, at: int, now: float) -> int:
        """``data`` from ``at`` byte by byte up to the end of a line (run) or of ``data``;
        where the next line starts."""
        echo = bytearray()
        for index in range(at, len(data)):
            byte = data[index]
            if byte in (CR, LF):
                if line.echo:
                    echo += b"\r\n"
                if echo:
                    self.send(line, bytes(echo), now)
                text = "".join(line.buffer)
                overflow = line.overflow
                self._reset(line)
                self._complete(line_id, line, text, overflow, now)
                return index + 1
            elif byte == ESC:
                if echo:
                    self.send(line, bytes(echo), now)
                    echo = bytearray()
                self._break(line, now)
            elif byte in (BS, DEL):
                if line.buffer:
                    line.buffer.pop()
                    if line.echo:
                        echo += b"\b \b"
            else:
                if line.started is None:
                    line.started = now
                    if byte == ord("+"):
                        line.echo = True  # §3.4.2
                        echo += b"+"
                        continue
                if len(line.buffer) < MAX_LINE:
                    line.buffer.append(chr(byte))
                    if line.echo:
                        echo.append(byte)
                else:
                    line.overflow = True
        if echo:
            self.send(line, bytes(echo), now)
        return len(data)

    def _complete(self, line_id: int, line: _Line, text: str, overflow: bool, now: float) -> None:
        answer, speed = self._command(line_id, line, text, overflow, now)
        if answer is not None:
            self._deliver(line, text, answer, now, speed)

    def _command(
        self, line_id: int, line: _Line, text: str, overflow: bool, now: float
    ) -> tuple[Answer | None, int | None]:
        """A completed command line runs: its answer (None: silence, an empty line, or the
        line waits) and the rate it goes at."""
        if not text.strip(" "):
            return None, None  # an empty line gets no answer
        line.blocks_messages = True  # §6.14.9.2: the first command blocks messages
        self._blocking.add(line_id)
        speed = self.com_speed  # `write com speed` takes effect after its own OK (§6.11.2)
        return self._answer(line_id, line, text, now, speed, overflow=overflow), speed

    def _answer(
        self,
        line_id: int,
        line: _Line,
        text: str,
        now: float,
        speed: int | None,
        *,
        overflow: bool = False,
        paused: bool = False,
    ) -> Answer | None:
        """Run ``text``: its answer, or None (silence, or the line waits: ``line.pending``)."""
        try:
            answer = self.interpreter.run_line(text, now, overflow=overflow, paused=paused)
        except NeedWait as wait:  # §8.5.1 pause, §6.5.13 sensors: the line runs again later
            delay = wait.seconds * (self.scale if wait.line_time else 1.0)
            line.pending, line.run_at, line.speed = text, now + delay, speed
            self._busy[line_id] = line
            return None
        except Exception:  # DESIGN.md point 6: never stop the device loop
            log.exception("internal error on line %r", text)
            answer = self.interpreter.error_answer(text)
        if answer is not None and answer.release:
            line.blocks_messages = False  # `write com close` (§6.11.8)
            self._blocking.discard(line_id)
        return answer

    def _deliver(
        self, line: _Line, text: str, answer: Answer, now: float, speed: int | None
    ) -> None:
        """Send an answer on its line; start the XMODEM transfer it announces."""
        if answer.data:
            self.send(line, answer.data, now, answer.baud or speed)
        if answer.transfer is not None:
            transfers.start(self, line, text, answer.transfer, now, answer.baud or speed)
