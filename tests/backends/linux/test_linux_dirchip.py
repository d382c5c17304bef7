"""GPIO without a gpiochip (issue 26): in a fake tree, ``dev/gpiochip0`` as a directory is a
chip whose output lines are files and whose pulse lines are named pipes, so the board file of
a Raspberry Pi runs unchanged and a user sees the outputs and feeds the pulse counter."""

from __future__ import annotations

import asyncio
import os
import stat
import time
from pathlib import Path

import pytest

from sondalog.app.logger import start_logger
from sondalog.backends.linux.board import load_board
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.config import ConfigError
from sondalog.io.clock import RealClock

BOARD = """\
[board]
[[board.pulses]]
timer = true
chip = "gpiochip0"
line = "GPIO17"
edge = "falling"

[[board.outputs]]
output = 2
chip = "gpiochip0"
line = 27
active_low = true
"""


def _board(tmp_path: Path, text: str = BOARD) -> LinuxHardware:
    (tmp_path / "root/dev/gpiochip0").mkdir(parents=True, exist_ok=True)
    site = tmp_path / "board.toml"
    site.write_text(text)
    board = load_board(site)
    assert board is not None
    return LinuxHardware(board, root=tmp_path / "root")


def _write(path: Path, data: bytes) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)  # as `echo 3 > line17` does
    try:
        os.write(fd, data)
    finally:
        os.close(fd)


def test_outputs_are_files_holding_their_level(tmp_path: Path) -> None:
    hw = _board(tmp_path)
    line = tmp_path / "root/dev/gpiochip0/line27"
    try:
        assert line.read_text() == "0\n"  # requested inactive
        hw.set_output(2, True, time.time())
        assert line.read_text() == "1\n"  # active (the relay board inverts it: active_low)
        hw.set_output(2, False, time.time())
        assert line.read_text() == "0\n"
        hw.set_output(2, True, time.time())
    finally:
        hw.close()
    assert line.read_text() == "0\n"  # released inactive, as on a board


def test_pulses_written_to_the_line_are_counted(tmp_path: Path) -> None:
    hw = _board(tmp_path)
    pipe = tmp_path / "root/dev/gpiochip0/line17"
    start = time.time()
    try:
        assert stat.S_ISFIFO(pipe.stat().st_mode)
        _write(pipe, b"3\n\n")  # three pulses, then one (an empty line)
        assert hw.pulses(1, 0, True, start - 1, time.time() + 1) == 4
        _write(pipe, b"2")  # half a line: nothing yet
        assert hw.pulses(1, 0, True, start - 1, time.time() + 1) == 4
        _write(pipe, b"\nmany\n-1\n")  # the rest of it; words and negatives are ignored
        assert hw.pulses(1, 0, True, start - 1, time.time() + 1) == 6
        assert hw.pulses(1, 0, True, start - 60, start - 1) == 0  # they happened now
        assert hw.pulses(1, 17, False, start - 1, time.time() + 1) == 0  # not an ADC input
    finally:
        hw.close()
    assert not pipe.exists()  # a writer finds no pipe waiting for a reader that is gone


def test_the_acquisition_task_counts_pulses_as_they_come(tmp_path: Path) -> None:
    async def serve() -> int:
        hw = _board(tmp_path)
        task = asyncio.create_task(hw.run())
        start = time.time()
        try:
            await asyncio.sleep(0)  # the task registers the pipe with the event loop
            _write(tmp_path / "root/dev/gpiochip0/line17", b"5\n")
            for _ in range(100):
                await asyncio.sleep(0.01)
                if hw._pulses[0].counter.count(17, start - 1, time.time() + 1):
                    break
            return hw._pulses[0].counter.count(17, start - 1, time.time() + 1)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            hw.close()

    assert asyncio.run(serve()) == 5


def test_a_file_left_where_the_pipe_goes_is_replaced(tmp_path: Path) -> None:
    pipe = tmp_path / "root/dev/gpiochip0/line17"
    pipe.parent.mkdir(parents=True)
    pipe.write_text("1\n")  # `echo 1 > line17` while nothing was serving
    hw = _board(tmp_path)
    try:
        assert stat.S_ISFIFO(pipe.stat().st_mode)
        assert hw.pulses(1, 0, True, 0.0, time.time() + 1) == 0  # not counted later
    finally:
        hw.close()


@pytest.mark.parametrize(("line", "message"), [("'SPI0'", "no line 'SPI0'"), ("54", "no line 54")])
def test_a_line_the_chip_does_not_have(tmp_path: Path, line: str, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        _board(tmp_path, BOARD.replace('"GPIO17"', line))
    assert info.value.line == 5 and info.value.field == "board.pulses[0].line"
    assert message in str(info.value)


def test_stopping_the_logger_switches_the_outputs_off(tmp_path: Path) -> None:
    """A relay left on after `sondalog serve` stops would drain the battery: closing the
    logger releases the lines inactive (and removes the pulse pipe)."""

    async def serve() -> None:
        hw = _board(tmp_path)
        logger = await start_logger(tmp_path / "state", RealClock(), ("127.0.0.1", 0), hardware=hw)
        hw.set_output(2, True, time.time())
        assert (tmp_path / "root/dev/gpiochip0/line27").read_text() == "1\n"
        await logger.close()

    asyncio.run(serve())
    assert (tmp_path / "root/dev/gpiochip0/line27").read_text() == "0\n"
    assert not (tmp_path / "root/dev/gpiochip0/line17").exists()
