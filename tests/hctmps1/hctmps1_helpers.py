"""Helpers for the HCTMPS1 core tests: an independent CRC and a module on a test bench."""

from __future__ import annotations

import random
from collections.abc import Callable

from sondalog.hctmps1 import (
    TEMP,
    EepromStore,
    Hctmps1Module,
    MemoryEeprom,
    ModuleConfig,
    Variant,
)

T0 = 1_000_000.0


def crc_bitwise(data: bytes) -> int:
    """CRC-16/MODBUS computed bit by bit, independent of the table-driven one under test."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            lsb = crc & 1
            crc >>= 1
            if lsb:
                crc ^= 0xA001
    return crc


def frame(dst: str, src: str, body: str) -> bytes:
    """A frame built by hand from hctmps1.md §2."""
    covered = f"{dst},{src},{body}".encode()
    return b":" + covered + b"|" + f"{crc_bitwise(covered):04X}".encode() + b"\r\n"


class Bench:
    """One module, its EEPROM and a clock the test moves by hand."""

    def __init__(
        self,
        variant: Variant = TEMP,
        module_id: str = "T1",
        value: float = 21.4375,
        eeprom: EepromStore | None = None,
        seed: int = 1,
        now: float = T0,
    ) -> None:
        self.now = now
        self.value = value
        self.signal: Callable[[float], float] | None = None
        self.eeprom = eeprom if eeprom is not None else MemoryEeprom()
        self.module = Hctmps1Module(
            ModuleConfig(module_id, variant),
            self._sample,
            self.eeprom,
            random.Random(seed),
            now,
        )

    def _sample(self, t: float) -> float:
        return self.signal(t) if self.signal is not None else self.value

    def send(self, data: bytes, dt: float = 0.0) -> bytes:
        self.now += dt
        return self.module.handle(data, self.now).data

    def ask(self, body: str, dst: str | None = None, src: str = "PC", dt: float = 0.0) -> bytes:
        return self.send(frame(dst or self.module.module_id, src, body), dt)

    def connect(self, src: str = "PC", password: str = "0000") -> None:
        assert self.ask(f"CONNECT.{password}", src=src) == frame(
            src, self.module.module_id, "RCONNECT.<OK>"
        )
