"""A real RS-485 adapter for the HCTMPS1 bus (hctmps1.md §1, §2; docs/hctmps1.md timing).

The port itself is opened by :mod:`sondalog.io.rs485` (the bus master uses it too).
RS-485 is half duplex: the side that talks enables its line driver (DE, usually wired to
the UART's RTS) for exactly as long as its frame lasts. Three ways to get that on Linux:

- ``kernel``: the UART driver toggles RTS itself (``TIOCSRS485``; Raspberry Pi PL011 and
  8250 UARTs, many USB adapters' drivers). The best choice where the driver supports it.
- ``rts``: pyserial's :class:`serial.rs485.RS485` raises RTS, writes, waits until the last
  stop bit has left (``tcdrain``) and drops RTS. Works on any UART with an RTS line, but the
  write blocks for the frame's duration (so it runs in a worker thread,
  :class:`sondalog.io.rs485.AsyncPort`) and the release is only as precise as the scheduler.
- ``auto``: the adapter switches direction by itself (most USB RS-485 sticks); the port is a
  plain 8N1 port.

Bus timing (sondalog's HCTMPS1 decisions): a byte is 10 bit times; a module answers
:data:`~sondalog.protocol.hctmps1_frames.TURNAROUND` (2 ms) after the end of a request, so the
master must release the driver sooner than that; a broadcast is answered within 16 slots of
an 80-byte frame each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sondalog.hctmps1.module import BROADCAST_SLOTS
from sondalog.io.rs485 import MODES, Mode, Rs485Error, open_port
from sondalog.protocol.hctmps1_frames import TURNAROUND, inter_frame_gap, slot_time
from sondalog.world import medium


@dataclass(frozen=True, slots=True)
class BusTiming:
    """Line times of the HCTMPS1 bus at one speed."""

    baud: int

    @property
    def byte_time(self) -> float:
        return medium.byte_time(self.baud)

    def frame_time(self, nbytes: int) -> float:
        """Seconds a frame of ``nbytes`` bytes occupies the line."""
        return nbytes * self.byte_time

    @property
    def turnaround(self) -> float:
        """A module starts its answer this long after the end of a request."""
        return TURNAROUND

    @property
    def inter_frame_gap(self) -> float:
        """Idle line the master leaves between the end of an answer (or of a silent request)
        and its next request: the module turnaround plus 3.5 byte times, so a late answer
        is never overrun (:func:`~sondalog.protocol.hctmps1_frames.inter_frame_gap`)."""
        return inter_frame_gap(self.baud)

    @property
    def broadcast_window(self) -> float:
        """How long answers to a broadcast may keep coming (hctmps1.md §2)."""
        return self.turnaround + BROADCAST_SLOTS * slot_time(self.baud)


@dataclass(frozen=True, slots=True)
class Rs485Settings:
    """How a served bus drives its adapter (``[bus.serve]`` or ``[board.rs485]``)."""

    mode: Mode = "auto"
    delay_before_tx: float = 0.0
    delay_before_rx: float = 0.0


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
    """Open ``port`` 8N1 at ``baud`` as an RS-485 line in ``mode``; a pyserial ``Serial``
    (:func:`sondalog.io.rs485.open_port`, its driver delays checked against the bus timing).

    Raises :class:`Rs485Error` when the port cannot do the mode (a pty, or a UART whose driver
    lacks ``TIOCSRS485``, in ``kernel`` mode; a port without modem lines in ``rts`` mode) and
    ``serial.SerialException`` when it cannot be opened at all.
    """
    if mode not in MODES:
        raise Rs485Error(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
    check_delays(baud, delay_before_tx, delay_before_rx)
    return open_port(
        port,
        baud,
        mode=mode,
        delay_before_tx=delay_before_tx,
        delay_before_rx=delay_before_rx,
        rts_level_for_tx=rts_level_for_tx,
        timeout=timeout,
    )


__all__ = [
    "MODES",
    "BusTiming",
    "Mode",
    "Rs485Error",
    "Rs485Settings",
    "check_delays",
    "open_rs485",
]
