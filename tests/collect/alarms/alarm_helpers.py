"""Helpers of the alarm tests: plans from TOML text, samples."""

from __future__ import annotations

from pathlib import Path

from sondalog.collect.alarms import AlarmPlan, Sample, parse_alarms
from sondalog.config import loads

T0 = 1_700_000_000.0


def plan_of(text: str) -> AlarmPlan:
    return parse_alarms(loads(text, Path("collector.toml")))


def sample(value: float | None, t: float, logger: str = "F01", channel: int = 1) -> Sample:
    return Sample("station-1", logger, channel, value, T0 + t, name="Air")
