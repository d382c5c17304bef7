"""RS-485 line settings on real ports; a pty stands in for the adapter where it can."""

from __future__ import annotations

import os
import tty

import pytest

from sondalog.backends.linux.rs485 import BusTiming, Rs485Error, open_rs485
from sondalog.hctmps1 import encode_frame


@pytest.fixture
def pty_pair() -> tuple[int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    yield master, name
    os.close(slave)
    os.close(master)


def test_auto_direction_adapter_carries_a_frame(pty_pair: tuple[int, str]) -> None:
    master, name = pty_pair
    line = open_rs485(name, 9600, mode="auto", timeout=1.0)
    try:
        assert (line.baudrate, line.bytesize, line.parity, line.stopbits) == (9600, 8, "N", 1)
        frame = encode_frame("T1", "HOST", "HELLO")
        line.write(frame)
        line.flush()
        got = b""
        while len(got) < len(frame):
            got += os.read(master, 256)
        assert got == frame
        os.write(master, b":HOST,T1,RHELLO|0000\r\n")
        assert line.readline() == b":HOST,T1,RHELLO|0000\r\n"
    finally:
        line.close()


def test_kernel_mode_on_a_pty_is_refused_clearly(pty_pair: tuple[int, str]) -> None:
    _, name = pty_pair
    with pytest.raises(Rs485Error, match=r"kernel RS-485 mode not supported.*use mode"):
        open_rs485(name, 9600, mode="kernel")
    with pytest.raises(Rs485Error, match="no RTS line"):
        open_rs485(name, 9600, mode="rts")


def test_delays_must_fit_the_module_turnaround(pty_pair: tuple[int, str]) -> None:
    _, name = pty_pair
    with pytest.raises(Rs485Error, match="turnaround"):
        open_rs485(name, 9600, mode="auto", delay_before_rx=0.002)
    with pytest.raises(Rs485Error, match="mode"):
        open_rs485(name, 9600, mode="magic")  # type: ignore[arg-type]


def test_bus_timing_at_9600() -> None:
    timing = BusTiming(9600)
    assert timing.byte_time == pytest.approx(10 / 9600)
    assert timing.frame_time(80) == pytest.approx(80 * 10 / 9600)
    assert timing.inter_frame_gap == pytest.approx(0.002 + 3.5 * 10 / 9600)
    assert timing.broadcast_window == pytest.approx(0.002 + 16 * 80 * 10 / 9600)


@pytest.mark.hardware
def test_kernel_mode_on_a_real_uart() -> None:
    """On a board: SONDALOG_RS485_PORT=/dev/ttyAMA0 (a UART whose driver has TIOCSRS485)."""
    port = os.environ.get("SONDALOG_RS485_PORT", "/dev/ttyAMA0")
    line = open_rs485(port, 9600, mode="kernel")
    try:
        assert line.rs485_mode is not None
    finally:
        line.close()
