"""A real RS-485 adapter for the HCTMPS1 bus (hctmps1.md §1, §2; docs/hctmps1.md timing).

RS-485 is half duplex: the side that talks enables its line driver (DE, usually wired to
the UART's RTS) for exactly as long as its frame lasts. Three ways to get that on Linux:

- ``kernel``: the UART driver toggles RTS itself (``TIOCSRS485``; Raspberry Pi PL011 and
  8250 UARTs, many USB adapters' drivers). The best choice where the driver supports it.
- ``rts``: pyserial's :class:`serial.rs485.RS485` raises RTS, writes, waits until the last
  stop bit has left (``tcdrain``) and drops RTS. Works on any UART with an RTS line, but the
  write blocks for the frame's duration and the release is only as precise as the scheduler.
- ``auto``: the adapter switches direction by itself (most USB RS-485 sticks); the port is a
  plain 8N1 port.

Bus timing (sondalog's HCTMPS1 decisions): a byte is 10 bit times; a module answers
:data:`~sondalog.world.bus.DEFAULT_TURNAROUND` (2 ms) after the end of a request, so the
master must release the driver sooner than that; a broadcast is answered within 16 slots of
an 80-byte frame each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from sondalog.hctmps1.module import BROADCAST_SLOTS
from sondalog.protocol.hctmps1_frames import slot_time
from sondalog.world.bus import DEFAULT_TURNAROUND

Mode = Literal["kernel", "rts", "auto"]
MODES: tuple[Mode, ...] = ("kernel", "rts", "auto")
#: Bits per byte on the line: start, 8 data, stop (8N1).
BITS_PER_BYTE = 10


class Rs485Error(ValueError):
    """The port cannot be driven as asked (settings out of range, mode not supported)."""


@dataclass(frozen=True, slots=True)
class BusTiming:
    """Line times of the HCTMPS1 bus at one speed."""

    baud: int

    @property
    def byte_time(self) -> float:
        return BITS_PER_BYTE / self.baud

    def frame_time(self, nbytes: int) -> float:
        """Seconds a frame of ``nbytes`` bytes occupies the line."""
        return nbytes * self.byte_time

    @property
    def turnaround(self) -> float:
        """A module starts its answer this long after the end of a request."""
        return DEFAULT_TURNAROUND

    @property
    def inter_frame_gap(self) -> float:
        """Idle line the master leaves between the end of an answer (or of a silent request)
        and its next request: the module turnaround plus 3.5 byte times, so a late answer
        is never overrun (sondalog decision, modelled on Modbus RTU's 3.5 characters)."""
        return self.turnaround + 3.5 * self.byte_time

    @property
    def broadcast_window(self) -> float:
        """How long answers to a broadcast may keep coming (hctmps1.md §2)."""
        return self.turnaround + BROADCAST_SLOTS * slot_time(self.baud)


def check_delays(baud: int, delay_before_tx: float, delay_before_rx: float) -> None:
    """Driver delays must fit the bus timing: releasing the driver later than the module
    turnaround would collide with the answer."""
    if not 0.0 <= delay_before_tx <= 0.1:
        raise Rs485Error(f"delay_before_tx must be 0..0.1 s, not {delay_before_tx}")
    turnaround = BusTiming(baud).turnaround
    if not 0.0 <= delay_before_rx < turnaround:
        raise Rs485Error(
            f"delay_before_rx must be >= 0 and shorter than the modules' turnaround "
            f"({turnaround * 1000:g} ms), not {delay_before_rx}"
        )


def open_rs485(
    port: str,
    baud: int = 9600,
    *,
    mode: Mode = "kernel",
    delay_before_tx: float = 0.0,
    delay_before_rx: float = 0.0,
    rts_level_for_tx: bool = True,
    timeout: float | None = 0.0,
) -> Any:
    """Open ``port`` 8N1 at ``baud`` as an RS-485 line in ``mode``; a pyserial ``Serial``.

    Raises :class:`Rs485Error` when the port cannot do the mode (a pty, or a UART whose driver
    lacks ``TIOCSRS485``, in ``kernel`` mode; a port without modem lines in ``rts`` mode) and
    ``serial.SerialException`` when it cannot be opened at all.
    """
    import serial
    import serial.rs485

    from sondalog.io.serial_ports import serial_8n1

    if mode not in MODES:
        raise Rs485Error(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    check_delays(baud, delay_before_tx, delay_before_rx)
    settings = serial.rs485.RS485Settings(
        rts_level_for_tx=rts_level_for_tx,
        rts_level_for_rx=not rts_level_for_tx,
        delay_before_tx=delay_before_tx,
        delay_before_rx=delay_before_rx,
    )
    cls = serial.rs485.RS485 if mode == "rts" else serial.Serial
    line = cls(port, baud, timeout=timeout, **serial_8n1())
    try:
        if mode == "kernel":
            line.rs485_mode = settings  # TIOCSRS485 on Linux
        elif mode == "rts":
            line.rts = not rts_level_for_tx  # receiving until the first write
            line.rs485_mode = settings  # pyserial toggles RTS around each write
    except (ValueError, OSError) as exc:
        line.close()
        hint = (
            "the port's driver has no kernel RS-485 mode (a pty or a plain USB serial "
            "adapter): use mode = 'rts' or 'auto'"
            if mode == "kernel"
            else "the port has no RTS line (a pty?): use mode = 'auto'"
        )
        raise Rs485Error(f"{port}: {mode} RS-485 mode not supported: {exc}; {hint}") from None
    return line
