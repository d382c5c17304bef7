"""Check a board file on the board: ``python -m sondalog.backends.linux BOARD.toml``.

Reads every wired input once and prints what the logger would see: each DS18B20 with its
ROM code as the logger writes it (§6.4.3.1.1), each IIO input in volts and as the core's
normalised reading, the supply, and the pulses counted while it watched. Exit 2 on a wrong
board file (file:line: field: message).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from pathlib import Path

from sondalog.ala1.hardware import SUPPLY_DIVIDER
from sondalog.backends.linux.board import load_board
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.backends.linux.iio import INTERNAL_REFERENCE
from sondalog.backends.linux.w1 import slave_from_rom
from sondalog.config import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sondalog.backends.linux")
    parser.add_argument("site", type=Path, help="site file with [board], or a board file")
    parser.add_argument("--root", type=Path, default=Path("/"), help="prefix of /sys and /dev")
    parser.add_argument("--watch", type=float, default=0.0, help="seconds to count pulses")
    args = parser.parse_args(argv)
    try:
        board = load_board(args.site)
        if board is None:
            raise ConfigError(args.site, "board", "no [board] table and no board = FILE")
        hw = LinuxHardware(board, root=args.root)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        start = time.time()
        asyncio.run(hw.acquire())
        if args.watch > 0:
            time.sleep(args.watch)
        now = time.time()
        for wire in board.ds18b20:
            found = hw.thermometers(wire.pin)
            for rom, celsius in sorted(found.items()):
                value = "no valid value" if celsius is None else f"{celsius:.4f} °C"
                print(f"ds18b20 P6.{wire.pin} {slave_from_rom(rom)} = {rom:016X}: {value}")
            if not found:
                print(f"ds18b20 P6.{wire.pin} ({wire.master}): no sensor found")
        for address in sorted(a.address for a in board.analog if a.address is not None):
            reading = hw.adc(1, address, now)
            shown = "no valid value" if reading is None else f"{reading:.4f} of the reference"
            volts = "" if reading is None else f" ({reading * INTERNAL_REFERENCE:.4f} V int. ref)"
            print(f"analog {address}: {shown}{volts}")
        if board.supply is not None:
            supply = hw.supply(now)
            print(
                "supply: "
                + (
                    "no valid value"
                    if supply is None
                    else f"{supply * INTERNAL_REFERENCE * SUPPLY_DIVIDER:.2f} V"
                )
            )
        for p in board.pulses:
            name = "timer P1.0" if p.timer else f"input {p.address}"
            count = hw.pulses(1, p.address, p.timer, start, time.time() + 1)
            print(f"pulses {name} ({p.chip} line {p.line}): {count}")
    finally:
        hw.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
