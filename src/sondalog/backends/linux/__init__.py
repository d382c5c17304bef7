"""The ``linux`` hardware backend: an ALA1 logger on a Linux board with real sensors.

1-Wire DS18B20 (:mod:`.w1`), IIO A/D inputs (:mod:`.iio`), libgpiod outputs and pulse
inputs (:mod:`.gpio`), RS-485 adapters (:mod:`.rs485`), wired by a board file
(:mod:`.board`); docs/linux-board.md shows a Raspberry Pi set up step by step.
"""

from __future__ import annotations

from pathlib import Path

from sondalog.backends.linux.board import BoardConfig, load_board, parse_board
from sondalog.backends.linux.hardware import LinuxHardware

NAME = "linux"


def create(site_dir: Path, board: BoardConfig, *, root: Path = Path("/")) -> LinuxHardware:
    """The board's hardware, its GPIO lines requested; ``root`` prefixes every sysfs and
    ``/dev`` path (a fake tree in tests). ``site_dir`` is where the site file lives."""
    return LinuxHardware(board, root=root)


__all__ = ["NAME", "BoardConfig", "LinuxHardware", "create", "load_board", "parse_board"]
