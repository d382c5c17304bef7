"""The ``linux`` hardware backend: an ALA1 logger on a Linux board with real sensors.

1-Wire DS18B20 (:mod:`.w1`), IIO A/D inputs (:mod:`.iio`), libgpiod outputs and pulse
inputs (:mod:`.gpio`), RS-485 adapters (:mod:`.rs485`), wired by a board file
(:mod:`.board`); docs/linux-board.md shows a Raspberry Pi set up step by step.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from sondalog.backends.linux.board import (
    BoardConfig,
    load_board,
    parse_board,
    read_board,
    read_board_of_site,
)
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.config import of

if TYPE_CHECKING:
    from sondalog.backends.registry import BackendContext

NAME = "linux"


def open_board(board: BoardConfig, *, root: Path = Path("/")) -> LinuxHardware:
    """The board's hardware, its GPIO lines requested; ``root`` prefixes every sysfs and
    ``/dev`` path (a fake tree in tests)."""
    return LinuxHardware(board, root=root)


def create(context: BackendContext) -> LinuxHardware:
    """The registry's entry (``backend = "linux"``): the site file's board, on ``root``."""
    site = of(context.site, context.path, context.text)
    if context.speed != 1:  # the cached readings would be stamped on one clock, read on another
        raise site.source.fail(
            "logger.backend",
            f"--speed {context.speed:g}: a real board's sensors, conversions and pulses keep "
            'real time; serve it without --speed (backend = "sim" runs faster)',
        )
    board = read_board_of_site(site)
    if board is None:
        raise site.fail("board", 'backend "linux" needs a [board] table or board = "FILE"')
    return open_board(board, root=context.root)


__all__ = [
    "NAME",
    "BoardConfig",
    "LinuxHardware",
    "create",
    "load_board",
    "open_board",
    "parse_board",
    "read_board",
    "read_board_of_site",
]
