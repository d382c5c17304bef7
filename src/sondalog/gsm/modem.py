"""A Wavecom GSM/GPRS modem (the ALA GPRS of manual §6.11.5.2) as a pure core.

The logger (or gammu, or a person on a terminal) talks to it with AT commands on a serial
line at ``com speed``; the network talks to it with :mod:`sondalog.gsm.events`. The core never
reads a clock: every call gets ``now`` and returns an :class:`Output` (bytes for the line,
effects for the network); :meth:`Modem.next_deadline` says when to call :meth:`Modem.advance`
(ring repetition, auto-answer, the ``+++`` guard time). The dialect is the gsm notes
(docs/gsm-notes.md) §2: V.250 basics, 3GPP TS 27.007 (calls, registration, signal, USSD),
27.005 (SMS, text and PDU mode; :mod:`sondalog.gsm.modem_sms`) and Wavecom's WIPsoft GPRS/TCP
commands (:mod:`sondalog.gsm.wip`). ``docs/gsm.md`` lists every answer.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from sondalog.gsm import events as ev
from sondalog.gsm import modem_basic, modem_calls, modem_sms, wip
from sondalog.gsm.at_modem import ActiveCall, Handler, Settings, WipState
from sondalog.gsm.at_modem import ModemConfig as ModemConfig
from sondalog.gsm.atline import (
    EXEC,
    NO_FINAL,
    READ,
    SET,
    TEST,
    AtSyntaxError,
    CmeError,
    CmsError,
    Finish,
    format_info,
    format_result,
    parse_line,
)
from sondalog.gsm.smsstore import SmsStore

log = logging.getLogger(__name__)

#: Seconds of silence before and after ``+++`` (V.250 S12 = 50 x 20 ms).
GUARD_TIME = 1.0
#: Longest command line kept (longer: ``ERROR``).
MAX_LINE = 2048
#: Data from the far end kept while in online command mode.
MAX_HELD = 65536

COMMAND = "command"
SMS_INPUT = "sms-input"
DATA = "data"

CTRL_Z = 0x1A
ESC = 0x1B
BACKSPACE = 0x08

_TCP_EVENTS = (ev.TcpConnected, ev.TcpFailed, ev.TcpIncoming, ev.TcpData, ev.TcpClosed)

Tracer = Callable[[str, bytes, float], None]


@dataclass(frozen=True, slots=True)
class Output:
    """What one call into the core produced."""

    data: bytes = b""
    effects: tuple[ev.Effect, ...] = ()


class Modem:
    """One modem: :meth:`receive` bytes from the DTE, :meth:`event` from the network,
    :meth:`advance` at :meth:`next_deadline`."""

    def __init__(self, config: ModemConfig | None = None, trace: Tracer | None = None) -> None:
        self.config = config or ModemConfig()
        self.trace = trace
        self.settings = Settings()
        self.store = SmsStore(self.config.store_size)
        self.smsc = self.config.smsc
        self.speed = self.config.speed
        self.radio = True
        self.registered = False
        self.rssi = 99
        self.mode = COMMAND
        self.call: ActiveCall | None = None
        self.mr = 0
        self.wip = WipState()
        self.data_target: int | None = None  # None: the call; else a WIPsoft socket handle
        self.sms_destination = ""
        self.sms_length = 0
        self._line = bytearray()
        self._sms = bytearray()
        self._out = bytearray()
        self._effects: list[ev.Effect] = []
        self._held_urcs: list[bytes] = []
        self._held_data = bytearray()
        self._last_data = 0.0
        self._plus: list[float] = []
        self._chunk = bytearray()  # data-mode bytes of this receive() for the far end
        self._escape_at: float | None = None
        self._busy = False  # a command line runs or awaits its final result
        self.handlers: dict[str, Handler] = {}
        for module in (modem_basic, modem_calls, modem_sms, wip):
            self.handlers.update(module.HANDLERS)

    # -- the three entry points ----------------------------------------------------------
    def receive(self, data: bytes, now: float) -> Output:
        """Bytes from the DTE (the logger's com line)."""
        if self.trace and data:
            self.trace("rx", data, now)
        for byte in data:
            if self.mode == DATA:
                self._data_byte(byte, now)
            elif self.mode == SMS_INPUT:
                self._sms_byte(byte, now)
            else:
                self._command_byte(byte, now)
        self._send_data()
        return self._take(now)

    def event(self, event: ev.Event, now: float) -> Output:
        """An event from the network."""
        if isinstance(event, ev.SmsDelivered):
            modem_sms.delivered(self, event)
        elif isinstance(event, _TCP_EVENTS):
            wip.network_event(self, event, now)
        else:
            modem_basic.network_event(self, event, now)
        return self._take(now)

    def advance(self, now: float) -> Output:
        """Timers: the ``+++`` guard after the escape, ring repetition, auto-answer."""
        if self._escape_at is not None and now >= self._escape_at:
            self._escape_at = None
            self._plus.clear()
            self.leave_data_mode()
            self.final("OK")
            wip.after_escape(self)
        modem_calls.ring_timer(self, now)
        return self._take(now)

    def next_deadline(self) -> float | None:
        ring = self.call.next_ring if self.call is not None else None
        times = [t for t in (self._escape_at, ring) if t is not None]
        return min(times) if times else None

    # -- output helpers used by the command modules --------------------------------------
    def emit(self, data: bytes) -> None:
        self._out += data

    def effect(self, effect: ev.Effect) -> None:
        self._effects.append(effect)

    def info(self, *lines: str) -> None:
        """Information text: one ``<CR><LF>`` before the first line, one after each."""
        if not lines:
            return
        text = "\r\n".join(lines)
        self._out += format_info(text, self.settings.verbose)

    def final(self, code: str) -> None:
        """The final result code of the command line (URCs held meanwhile follow it)."""
        self._busy = False
        if not self.settings.quiet:
            self._out += format_result(code, self.settings.verbose)
        if self.mode == COMMAND:
            self._flush_urcs()

    def urc(self, text: str) -> None:
        """An unsolicited result code: now in command mode, else when back in it."""
        data = format_result(text, self.settings.verbose)
        if self.mode == COMMAND and not self._line and not self._busy:
            self._out += data
        else:
            self._held_urcs.append(data)

    def error_text(self, error: CmeError) -> str:
        if self.settings.cmee == 0:
            return "ERROR"
        kind = "CMS" if isinstance(error, CmsError) else "CME"
        return f"+{kind} ERROR: {error.code}"

    def next_mr(self) -> int:
        self.mr = (self.mr + 1) % 256
        return self.mr

    # -- data mode -----------------------------------------------------------------------
    def enter_data_mode(self, target: int | None, now: float) -> None:
        self.mode = DATA
        self.data_target = target
        self._last_data = now
        self._plus.clear()
        self._escape_at = None
        if self._held_data:
            self._out += self._held_data
            self._held_data.clear()

    def leave_data_mode(self) -> None:
        self.mode = COMMAND
        self._escape_at = None
        self._plus.clear()

    def far_data(self, data: bytes) -> None:
        """Bytes from the far end: on the line in data mode, held otherwise."""
        if self.mode == DATA:
            self._out += data
        else:
            room = MAX_HELD - len(self._held_data)
            self._held_data += data[:room]

    def drop_held_data(self) -> None:
        self._held_data.clear()

    def _data_byte(self, byte: int, now: float) -> None:
        plus = byte == ord("+")
        if plus and not self._plus and now - self._last_data >= GUARD_TIME:
            self._plus.append(now)
            return
        if plus and 0 < len(self._plus) < 3 and now - self._plus[0] <= GUARD_TIME:
            self._plus.append(now)
            if len(self._plus) == 3:
                self._escape_at = now + GUARD_TIME
            return
        self._chunk += b"+" * len(self._plus)
        self._chunk.append(byte)
        self._plus.clear()
        self._escape_at = None
        self._last_data = now

    def _send_data(self) -> None:
        data, self._chunk = bytes(self._chunk), bytearray()
        if not data:
            return
        if self.data_target is None:
            if self.call is not None and self.call.active:
                self.effect(ev.CallSend(data))
        else:
            wip.send(self, self.data_target, data)

    # -- SMS input -----------------------------------------------------------------------
    def _sms_byte(self, byte: int, now: float) -> None:
        if byte == CTRL_Z:
            self.mode = COMMAND
            text, self._sms = bytes(self._sms), bytearray()
            modem_sms.submit(self, text, now)
            return
        if byte == ESC:
            self.mode = COMMAND
            self._sms.clear()
            self.final("OK")
            return
        if self.settings.echo:
            self._out.append(byte)
        if byte == 0x0D:
            self._out += b"\n> " if self.settings.echo else b"\r\n> "
        if byte == BACKSPACE:
            if self._sms:
                self._sms.pop()
            return
        if len(self._sms) < 4 * MAX_LINE:
            self._sms.append(byte)

    def start_sms_input(self) -> None:
        self.mode = SMS_INPUT
        self._sms.clear()
        self._out += b"\r\n> "

    # -- command lines -------------------------------------------------------------------
    def _command_byte(self, byte: int, now: float) -> None:
        call = self.call
        if self._busy and call is not None and not call.incoming and not call.active:
            # any character aborts a dial in progress (V.250 §6.3.1)
            self.call = None
            self.effect(ev.HangUp())
            self.final("NO CARRIER")
            return
        if byte == ESC:
            self._line.clear()
            return
        if self.settings.echo:
            self._out.append(byte)
        if byte == 0x0D:
            line, self._line = bytes(self._line), bytearray()
            self._run_line(line, now)
        elif byte == 0x0A:
            return
        elif byte == BACKSPACE:
            if self._line:
                self._line.pop()
        elif len(self._line) <= MAX_LINE:
            self._line.append(byte)

    def _run_line(self, raw: bytes, now: float) -> None:
        if len(raw) > MAX_LINE:
            self.final("ERROR")
            return
        try:
            commands = parse_line(raw.decode("latin-1"))
        except AtSyntaxError:
            self.final("ERROR")
            return
        if commands is None:
            self._flush_urcs()
            return
        self._busy = True
        for command in commands:
            handler = self.handlers.get(command.name)
            if handler is None:
                self.final("ERROR")
                return
            try:
                lines = handler(self, command, now)
            except AtSyntaxError:
                self.final("ERROR")
                return
            except CmeError as error:
                self.final(self.error_text(error))
                return
            except Finish as finish:
                self.info(*finish.lines)
                if finish.final == NO_FINAL:
                    self._busy = False
                    self._flush_urcs()
                elif finish.final is not None:
                    self.final(finish.final)
                return
            except Exception:  # a bug must not stop the line (DESIGN.md point 6)
                log.exception("modem command %r failed", command)
                self.final("ERROR")
                return
            self.info(*lines)
        self.final("OK")

    def _flush_urcs(self) -> None:
        for data in self._held_urcs:
            self._out += data
        self._held_urcs.clear()

    def _take(self, now: float) -> Output:
        if self.mode == COMMAND and not self._line and not self._busy and self._held_urcs:
            self._flush_urcs()
        data, self._out = bytes(self._out), bytearray()
        effects, self._effects = tuple(self._effects), []
        if self.trace and data:
            self.trace("tx", data, now)
        return Output(data, effects)


__all__ = [
    "EXEC",
    "NO_FINAL",
    "READ",
    "SET",
    "TEST",
    "CmeError",
    "CmsError",
    "Finish",
    "Modem",
    "ModemConfig",
    "Output",
]
