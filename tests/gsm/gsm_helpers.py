"""A modem and a network on a stepped clock, for byte-exact AT exchanges."""

from __future__ import annotations

from collections.abc import Callable

from sondalog.gsm.modem import Modem, ModemConfig
from sondalog.gsm.network import Network
from sondalog.gsm.system import GsmSystem, SystemOutput

MODEM = "+420600000001"
PHONE = "+420700000001"
PHONE2 = "+420700000002"
T0 = 1_764_464_400.0  # 2025-11-30 01:00:00 UTC


class Bench:
    def __init__(self, echo: bool = False, **config: object) -> None:
        self.now = T0
        self.system = GsmSystem(Network())
        self.network = self.system.network
        self.network.add_phone(PHONE)
        self.network.add_phone(PHONE2)
        self.modem = Modem(ModemConfig(**config))  # type: ignore[arg-type]
        self.last = self.system.add_modem(MODEM, self.modem, self.now)
        if not echo:
            assert self.at("ATE0") == b"ATE0\r\r\nOK\r\n"

    def at(self, line: str | bytes, end: bytes = b"\r") -> bytes:
        data = line.encode("latin-1") if isinstance(line, str) else line
        return self.send(data + end)

    def send(self, data: bytes) -> bytes:
        self.last = self.system.modem_input(MODEM, data, self.now)
        return self.last.line(MODEM)

    def later(self, seconds: float) -> bytes:
        self.now += seconds
        self.last = self.system.advance(self.now)
        return self.last.line(MODEM)

    def net(self, fn: Callable[[Network, float], list[object]]) -> SystemOutput:
        self.last = self.system.network_call(fn(self.network, self.now), self.now)
        return self.last
