"""Deterministic readings for the sink tests and the benchmark."""

from __future__ import annotations

from datetime import datetime, timedelta

from sondalog.collect.model import Reading

T0 = datetime(2026, 1, 1)
UNITS = ("°C", "V", "%RH", "lx")


def rows(logger: str, first: int, count: int, channels: int = 3) -> list[Reading]:
    """Rows ``first .. first + count - 1`` of one logger, one reading per channel, 60 s apart."""
    out: list[Reading] = []
    for i in range(first, first + count):
        t = T0 + timedelta(minutes=i)
        for ch in range(1, channels + 1):
            value = None if (i + ch) % 97 == 0 else round(20 + ch + (i % 50) / 10, 2)
            unit = UNITS[(ch - 1) % len(UNITS)]
            out.append(Reading(logger, ch, t, 0, 1, value, name=f"T{ch}", unit=unit))
    return out


def text_row(logger: str, i: int, text: str) -> Reading:
    return Reading(logger, 0, T0 + timedelta(minutes=i), 1, 3, None, text=text)
