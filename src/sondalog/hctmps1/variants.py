"""The two HCTMPS1 variants and how they measure (hctmps1.md §1, §4 "Values").

A variant knows the ``HELLO`` text, the conversion time of its sensor, and how a raw signal
value becomes the text of ``RPV.{value}``:

- temperature server, DS18B20: 0.0625 °C steps, -55..125 °C, 750 ms conversion (12 bit),
  sent with two decimals (``21.44``);
- humidity server, SHT11: 12-bit RH (0.04 %RH steps), 0..100 %RH, 80 ms conversion, sent with
  one decimal (``48.5``).

The signal itself comes from a :class:`SensorSource`, a callable giving the physical value at
a time, so the simulated signals of :mod:`sondalog.backends.sim.signals` and a Linux
hardware backend are interchangeable (DESIGN.md point 4).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Protocol


class SensorSource(Protocol):
    """The physical quantity at the sensor at time ``t`` (clock seconds)."""

    def __call__(self, t: float, /) -> float: ...


class Kind(enum.Enum):
    """The module variant, as the site file names it."""

    TEMP = "temp"
    HUM = "hum"


@dataclass(frozen=True, slots=True)
class Variant:
    """What tells the two HCTMPS1 variants apart (§1, §4)."""

    kind: Kind
    hello: str
    conversion_time: float
    step: float
    low: float
    high: float
    decimals: int

    def convert(self, physical: float) -> float:
        """The value the sensor reports for ``physical``: clamped, then quantised."""
        if math.isnan(physical):
            physical = self.low
        clamped = min(max(physical, self.low), self.high)
        return round(clamped / self.step) * self.step

    def format(self, value: float) -> str:
        """The ``{value}`` text of ``RPV.{value}`` (§4 "Values")."""
        text = f"{value:.{self.decimals}f}"
        return "0." + "0" * self.decimals if text == "-0." + "0" * self.decimals else text


TEMP = Variant(
    kind=Kind.TEMP,
    hello="HCTMPS1-temp server (DS18B20)",
    conversion_time=0.750,
    step=0.0625,
    low=-55.0,
    high=125.0,
    decimals=2,
)

HUM = Variant(
    kind=Kind.HUM,
    hello="HCTMPS1-hum server (SHT11)",
    conversion_time=0.080,
    step=100.0 / 2500.0,
    low=0.0,
    high=100.0,
    decimals=1,
)

VARIANTS: dict[Kind, Variant] = {Kind.TEMP: TEMP, Kind.HUM: HUM}


def variant_for(kind: Kind | str) -> Variant:
    """The variant for ``temp`` or ``hum``."""
    return VARIANTS[Kind(kind)]
