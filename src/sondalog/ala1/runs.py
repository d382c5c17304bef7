"""The RAM state of scheduled sampling (§6.5.13-§6.5.16, §6.7): each channel's run, the
outputs, the fault log, and what a sample makes of the record (averaging, §6.5.15; the change
and samples conditions, §6.5.16). Shared by the event-by-event path
(:mod:`sondalog.ala1.sampling`) and the series path (:mod:`sondalog.ala1.series`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from decimal import Decimal

from sondalog.ala1.hardware import Hardware
from sondalog.ala1.measure import ChannelConfig, format_value
from sondalog.ala1.moduleclock import to_seconds
from sondalog.ala1.tokens import parse_stamp

_ZERO = Decimal(0)
_NEVER = Decimal(-1)


@dataclass(slots=True)
class ChannelRun:
    """Sampling state of one channel (RAM, like the module's)."""

    cfg: ChannelConfig
    next_t: int | None = None
    last_t: int | None = None
    avg_sum: float = 0.0
    avg_n: int = 0
    since_write: int = 0
    recorded: str | None = None  # last value written to the record (formatted)
    event_active: bool = False  # type 6: the last sample met the condition
    sample: float | None = None  # last scheduled sample (unformatted)
    sampled: bool = False
    #: ``Measurer.compiled(cfg)``, made at the first sample after a configuration.
    measure: Callable[[float, float], float | None] | None = None

    def schedule(self, now: int) -> None:
        cfg = self.cfg
        if cfg.period <= 0:
            self.next_t = None
            return
        start = _stamp_seconds(cfg.start)
        if now <= start:
            self.next_t = start
        else:
            self.next_t = start + math.ceil((now - start) / cfg.period) * cfg.period


def _stamp_seconds(stamp: str) -> int:
    return int(to_seconds(parse_stamp(stamp)))


@dataclass
class Outputs:
    """The seven outputs (§6.7): a written value, or automatic switching (``NO``)."""

    hardware: Hardware
    manual: dict[int, str] = field(default_factory=dict)  # output -> "0" | "1" | "NO"
    usable: dict[int, bool] = field(default_factory=dict)  # device configured (§6.7.1)
    scheduled: dict[int, set[int]] = field(default_factory=dict)  # output -> channels powering
    held_until: dict[int, float] = field(default_factory=dict)  # module seconds
    on_since: dict[int, float] = field(default_factory=dict)  # module seconds, when on
    applied: dict[int, bool] = field(default_factory=dict)

    def is_on(self, output: int) -> bool:
        return self.applied.get(output, False)

    def update(self, now: float, offset: float) -> None:
        """Recompute every output's state at module time ``now`` and tell the hardware."""
        usable, applied = self.usable, self.applied
        for output in range(1, 8):
            if not usable.get(output, False):
                on = False
            elif (manual := self.manual.get(output, "NO")) != "NO":
                on = manual == "1"
            else:
                on = bool(self.scheduled.get(output)) or self.held_until.get(output, -1) > now
            if on != applied.get(output, False):
                self.applied[output] = on
                if on:
                    self.on_since[output] = now
                else:
                    self.on_since.pop(output, None)
                self.hardware.set_output(output, on, now - offset)


log = logging.getLogger("sondalog.ala1.sampling")


class FaultLog:
    """Internal errors of channels, logged at most once a minute per channel and cause."""

    INTERVAL = 60.0

    def __init__(self) -> None:
        self._last: dict[tuple[int, str], float] = {}

    def report(self, channel: int, exc: Exception, host_t: float) -> None:
        key = (channel, type(exc).__name__)
        last = self._last.get(key)
        if last is not None and 0 <= host_t - last < self.INTERVAL:
            return
        self._last[key] = host_t
        log.error(
            "channel %d: internal error while sampling (%s: %s); no valid value",
            channel,
            type(exc).__name__,
            exc,
        )


def decide(run: ChannelRun, value: float | None) -> str | None:
    """§6.5.15, §6.5.16: averaging, then the change and samples conditions."""
    cfg = run.cfg
    if cfg.average > 0:
        if value is not None:
            run.avg_sum += value
            run.avg_n += 1
        if run.avg_n < cfg.average:
            return None
        value = run.avg_sum / run.avg_n
        run.avg_sum, run.avg_n = 0.0, 0
    return record(run, format_value(cfg, value))


def record(run: ChannelRun, text: str) -> str | None:
    """§6.5.16: whether the value shown as ``text`` is written (its text, or None)."""
    cfg = run.cfg
    run.since_write += 1
    write: str | None = None
    change = cfg.change
    if change == _ZERO:
        write = text
    elif change != _NEVER:
        if cfg.type == 6:
            # §6.5.16.1: events per period; one 0 when the condition stops holding
            if text and decimal_of(text) >= change:
                write, run.event_active = text, True
            elif run.event_active:
                write, run.event_active = format_value(cfg, 0.0), False
        elif run.recorded is None or _changed(run.recorded, text, change):
            write = text
    if write is None and cfg.samples > 0 and run.since_write >= cfg.samples:
        write = text
    if write is not None:
        run.recorded = write
        run.since_write = 0
    return write


def _changed(old: str, new: str, change: Decimal) -> bool:
    if not old or not new:
        return old != new
    if old == new:  # (most samples: no arithmetic needed)
        return change <= _ZERO
    return abs(decimal_of(new) - decimal_of(old)) >= change


def decimal_of(text: str) -> Decimal:
    """``Decimal(text)``, remembered: recorded texts repeat (issue 24)."""
    number = _PARSED.get(text)
    if number is None:
        if len(_PARSED) >= 4096:
            _PARSED.clear()
        number = _PARSED[text] = Decimal(text)
    return number


_PARSED: dict[str, Decimal] = {}
