"""Signal models: what a simulated sensor measures over time (DESIGN.md point 4).

Every model is built from a TOML table (a dict) with a ``model`` key and returns a callable
``signal(t) -> value`` for clock time ``t`` in seconds, which is what a
:class:`sondalog.hctmps1.SensorSource` (and the ALA1 logger's simulated inputs) need. Times in
a table are seconds after the signal's *origin*: the ``origin`` key (clock seconds) if given,
else the start time the caller passes (the moment the simulation starts).

Models (``docs/hctmps1.md`` "Signal models"):

========== ===========================================================================
constant   ``value``
sine       ``mean``, ``amplitude``, ``period`` (s), ``phase`` (s, default 0)
ramp       ``start``, ``rate`` (units per second), ``min`` / ``max`` (optional clamp)
random_walk ``start``, ``step`` (std dev per interval), ``interval`` (s, default 60),
           ``seed`` (default 0), ``min`` / ``max`` (optional clamp)
steps      ``schedule``: ``[[t, value], ...]``, times ascending; holds each value
csv        ``path`` (relative to the site file), ``interpolate`` (default true),
           ``loop`` (default false); rows ``time,value``, an optional header line
========== ===========================================================================

Every model accepts ``origin``. A bad table raises :class:`ConfigError` naming the field
(:func:`read_signal` reads a table of a configuration file, with its file and line).
:func:`plan_signal` checks a table once into a :class:`SignalPlan` that is bound to the start
time later (a site file is loaded before its clock starts).
"""

from __future__ import annotations

import bisect
import math
import operator
import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from itertools import repeat, starmap
from pathlib import Path

from sondalog.backends.sim.instants import stride_of, walk_clamped
from sondalog.backends.sim.signal_points import points as _points
from sondalog.backends.sim.signal_points import read_csv_points
from sondalog.config import ConfigError, Table, of

Signal = Callable[[float], float]
_TWO_PI = 2.0 * math.pi  # (as :mod:`random`'s TWOPI; the same float as ``2 * math.pi``)


def _clamp(t: Table) -> Clamp:
    low, high = t.opt_number("min"), t.opt_number("max")
    lo = -math.inf if low is None else low
    hi = math.inf if high is None else high
    if lo > hi:
        raise t.fail("min", f"min {lo} is above max {hi}")
    return Clamp(lo, hi)


class Clamp:
    """``min(max(v, lo), hi)``."""

    __slots__ = ("hi", "lo")

    def __init__(self, lo: float, hi: float) -> None:
        self.lo, self.hi = lo, hi

    def __call__(self, v: float) -> float:
        return min(max(v, self.lo), self.hi)


def signal_column(signal: Signal, times: list[float], shift: float | None = None) -> list[float]:
    """``signal(t)`` (``signal(t - shift)`` with a shift) for each of ``times``: the very
    floats, in one pass where the signal offers a ``column`` method (issue 24: the simulation
    reads many instants at once)."""
    many = getattr(signal, "column", None)
    if many is not None:
        return many(times, shift)  # type: ignore[no-any-return]
    if shift is None:
        return [signal(t) for t in times]
    return [signal(t - shift) for t in times]


class Constant:
    """A value that never changes."""

    __slots__ = ("value",)

    def __init__(self, value: float) -> None:
        self.value = value

    def __call__(self, t: float) -> float:
        return self.value

    def column(self, times: list[float], shift: float | None = None) -> list[float]:
        return [self.value] * len(times)


def constant(value: float) -> Signal:
    """A value that never changes."""
    return Constant(value)


class Sine:
    """``mean + amplitude * sin(2π (t - origin - phase) / period)``."""

    __slots__ = ("amplitude", "mean", "origin", "period", "phase")

    def __init__(
        self, mean: float, amplitude: float, period: float, phase: float, origin: float
    ) -> None:
        self.mean, self.amplitude, self.period = mean, amplitude, period
        self.phase, self.origin = phase, origin

    def __call__(self, t: float) -> float:
        return self.mean + self.amplitude * math.sin(
            _TWO_PI * (t - self.origin - self.phase) / self.period
        )

    def column(self, times: list[float], shift: float | None = None) -> list[float]:
        mean, amplitude, period, sin = self.mean, self.amplitude, self.period, math.sin
        origin, phase = self.origin, self.phase
        if _plus_zero(origin) and _plus_zero(phase):  # (x - +0.0 is x, a -0.0 and a NaN too)
            if shift is None:
                return [mean + amplitude * sin(_TWO_PI * t / period) for t in times]
            return [mean + amplitude * sin(_TWO_PI * (t - shift) / period) for t in times]
        if shift is None:
            return [mean + amplitude * sin(_TWO_PI * (t - origin - phase) / period) for t in times]
        return [
            mean + amplitude * sin(_TWO_PI * (t - shift - origin - phase) / period) for t in times
        ]


def _plus_zero(x: float) -> bool:
    """``x`` is +0.0 (subtracting it leaves every float as it is; -0.0 does not: -0.0 -
    -0.0 is +0.0)."""
    return x == 0.0 and math.copysign(1.0, x) > 0.0


def sine(mean: float, amplitude: float, period: float, phase: float, origin: float) -> Signal:
    """``mean + amplitude * sin(2π (t - origin - phase) / period)``."""
    return Sine(mean, amplitude, period, phase, origin)


class Ramp:
    """``start + rate * (t - origin)``, clamped."""

    __slots__ = ("clamp", "origin", "rate", "start")

    def __init__(
        self, start: float, rate: float, origin: float, clamp: Callable[[float], float]
    ) -> None:
        self.start, self.rate, self.origin, self.clamp = start, rate, origin, clamp

    def __call__(self, t: float) -> float:
        return self.clamp(self.start + self.rate * (t - self.origin))

    def column(self, times: list[float], shift: float | None = None) -> list[float]:
        start, rate, origin, clamp = self.start, self.rate, self.origin, self.clamp
        if isinstance(clamp, Clamp):  # (one pass, as below)
            lo, hi = clamp.lo, clamp.hi
            if shift is None:
                return [
                    hi if hi < (w := lo if lo > (v := start + rate * (t - origin)) else v) else w
                    for t in times
                ]
            return [
                hi
                if hi < (w := lo if lo > (v := start + rate * (t - shift - origin)) else v)
                else w
                for t in times
            ]
        if shift is None:
            values = [start + rate * (t - origin) for t in times]
        else:
            values = [start + rate * (t - shift - origin) for t in times]
        if not isinstance(clamp, Clamp):
            return [clamp(v) for v in values]
        lo, hi = clamp.lo, clamp.hi  # min(max(v, lo), hi) written out, NaN and zeros alike
        return [hi if hi < (w := lo if lo > v else v) else w for v in values]


def ramp(start: float, rate: float, origin: float, clamp: Callable[[float], float]) -> Signal:
    """``start + rate * (t - origin)``, clamped."""
    return Ramp(start, rate, origin, clamp)


class Shifted:
    """``signal(t - start)``: a signal whose times count from the start of a simulation."""

    __slots__ = ("signal", "start")

    def __init__(self, signal: Signal, start: float) -> None:
        self.signal, self.start = signal, start

    def __call__(self, t: float) -> float:
        return self.signal(t - self.start)

    def column(self, times: list[float], shift: float | None = None) -> list[float]:
        if shift is not None:
            times = [t - shift for t in times]
        return signal_column(self.signal, times, self.start)


def shifted(signal: Signal, start: float) -> Signal:
    """``signal(t - start)`` for every ``t``."""
    return Shifted(signal, start)


#: Steps of a random walk made ahead of need.
_BATCH = 1024


class RandomWalk:
    """A seeded random walk: one normal step per interval, the same for every run."""

    def __init__(
        self,
        start: float,
        step: float,
        interval: float,
        seed: int,
        origin: float,
        clamp: Callable[[float], float],
    ) -> None:
        self._rng = random.Random(seed)
        self._step = step
        self._interval = interval
        self._origin = origin
        self._clamp = clamp
        self._values = [clamp(start)]
        self._spare: float | None = None  # the second of a Box-Muller pair, not used yet

    def __call__(self, t: float) -> float:
        index = int((t - self._origin) // self._interval)
        values = self._values
        if index >= len(values):
            self._extend(index)
        return values[index] if index > 0 else values[0]

    def column(self, times: list[float], shift: float | None = None) -> list[float]:
        """:meth:`__call__` at each of ``times`` (``t - shift``)."""
        if not times:
            return []
        origin, interval, values = self._origin, self._interval, self._values
        late = max(times) if shift is None else max(times) - shift
        top = int((late - origin) // interval)  # (the index grows with the time)
        if top >= len(values):
            self._extend(top)
        first = values[0]
        stride = stride_of(times, origin if shift is None else shift + origin, interval)
        if stride:  # (the instants step by whole intervals: the steps one after the other)
            begin = int((times[0] - origin) // interval if shift is None else
                        (times[0] - shift - origin) // interval)  # fmt: skip
            if begin > 0:
                return values[begin : begin + (len(times) - 1) * stride + 1 : stride]
        if shift is None:
            return [values[i] if (i := int((t - origin) // interval)) > 0 else first for t in times]
        return [
            values[i] if (i := int((t - shift - origin) // interval)) > 0 else first for t in times
        ]

    def _extend(self, index: int) -> None:
        """Steps up to ``index`` and a batch beyond. Each step is ``random.Random(seed)``'s
        next ``gauss(0, step)``: its Box-Muller pairs are made here, in the same order
        (issue 11: without a method call per step)."""
        values, clamp, step = self._values, self._clamp, self._step
        uniform, spare = self._rng.random, self._spare
        cos, sin, log, sqrt = math.cos, math.sin, math.log, math.sqrt
        count = index + _BATCH - len(values) + 1
        steps: list[float] = [] if spare is None else [spare]
        pairs = (count - len(steps) + 1) // 2
        draws = list(starmap(uniform, repeat((), 2 * pairs)))  # (x2pi's, g2rad's, alternately)
        angles = [u * _TWO_PI for u in draws[0::2]]
        radii = [sqrt(-2.0 * log(1.0 - u)) for u in draws[1::2]]
        pair = [0.0] * (2 * pairs)  # (cos(x) * g, sin(x) * g) of each pair, by C loops
        pair[0::2] = map(operator.mul, map(cos, angles), radii)
        pair[1::2] = map(operator.mul, map(sin, angles), radii)
        steps += pair
        spare = steps.pop() if len(steps) > count else None
        last = values[-1]
        append = values.append
        if isinstance(clamp, Clamp):  # min(max(v, lo), hi) written out
            walk_clamped(values, [0.0 + z * step for z in steps], clamp.lo, clamp.hi)
        else:
            for z in steps:
                last = clamp(last + (0.0 + z * step))
                append(last)
        self._spare = spare


class Schedule:
    """Piecewise values: ``(time after origin, value)`` points, held or interpolated."""

    def __init__(
        self,
        points: list[tuple[float, float]],
        origin: float,
        interpolate: bool,
        loop: bool,
    ) -> None:
        self._times = [p[0] for p in points]
        self._values = [p[1] for p in points]
        self._origin = origin
        self._interpolate = interpolate
        self._span = self._times[-1] - self._times[0] if loop else 0.0

    def __call__(self, t: float) -> float:
        x = t - self._origin
        if self._span > 0:
            x = self._times[0] + (x - self._times[0]) % self._span
        i = bisect.bisect_right(self._times, x) - 1
        if i < 0:
            return self._values[0]
        if i >= len(self._times) - 1 or not self._interpolate:
            return self._values[i]
        t0, t1 = self._times[i], self._times[i + 1]
        v0, v1 = self._values[i], self._values[i + 1]
        return v0 + (v1 - v0) * (x - t0) / (t1 - t0)


#: Every model and the keys its table may hold (besides ``model`` and ``origin``).
MODEL_KEYS: dict[str, frozenset[str]] = {
    "constant": frozenset({"value"}),
    "sine": frozenset({"mean", "amplitude", "period", "phase"}),
    "ramp": frozenset({"start", "rate", "min", "max"}),
    "random_walk": frozenset({"start", "step", "interval", "seed", "min", "max"}),
    "steps": frozenset({"schedule"}),
    "csv": frozenset({"path", "interpolate", "loop"}),
}
MODELS = tuple(MODEL_KEYS)


@dataclass(frozen=True, slots=True)
class SignalPlan:
    """A checked signal table, not yet bound to the time the simulation starts.

    Reading a file's signal table once (:func:`plan_signal`) checks everything (a CSV file is
    read then); :meth:`build` makes the signal when the simulation starts, its origin the
    table's ``origin`` or the start time."""

    model: str
    origin: float | None
    make: Callable[[float], Signal]  # origin -> the signal

    def build(self, start: float) -> Signal:
        """The signal of a simulation starting at clock time ``start``."""
        return self.make(start if self.origin is None else self.origin)


def build_signal(table: Mapping[str, object], start: float, base_dir: Path | None = None) -> Signal:
    """The signal described by the plain ``table`` (relative paths against ``base_dir``)."""
    return read_signal(of(table, root=base_dir), start)


def read_signal(t: Table, start: float) -> Signal:
    """The signal described by the table ``t`` (see the module docstring)."""
    return plan_signal(t).build(start)


def plan_signal(t: Table) -> SignalPlan:
    """Check the signal table ``t`` (see the module docstring) into a :class:`SignalPlan`."""
    model = t.text("model", choices=MODELS)
    t.keys(MODEL_KEYS[model] | {"model", "origin"})
    origin = t.opt_number("origin")
    return SignalPlan(model, origin, _MAKERS[model](t))


def _constant(t: Table) -> Callable[[float], Signal]:
    value = t.number("value")
    return lambda origin: constant(value)


def _sine(t: Table) -> Callable[[float], Signal]:
    mean, amplitude = t.number("mean"), t.number("amplitude")
    period, phase = t.number("period", above=0), t.number("phase", 0.0)
    return lambda origin: sine(mean, amplitude, period, phase, origin)


def _ramp(t: Table) -> Callable[[float], Signal]:
    start, rate, clamp = t.number("start"), t.number("rate"), _clamp(t)
    return lambda origin: ramp(start, rate, origin, clamp)


def _random_walk(t: Table) -> Callable[[float], Signal]:
    clamp = _clamp(t)
    start, step = t.number("start"), t.number("step", above=0)
    interval, seed = t.number("interval", 60.0, above=0), t.integer("seed", 0)
    return lambda origin: RandomWalk(start, step, interval, seed, origin, clamp)


def _steps(t: Table) -> Callable[[float], Signal]:
    try:
        points = _points(t.raw("schedule"), t.field("schedule"))
    except ConfigError as exc:
        raise t.source.fail(exc.field, exc.message) from None
    return lambda origin: Schedule(points, origin, False, False)


def _csv(t: Table) -> Callable[[float], Signal]:
    path = t.path("path")
    interpolate = t.flag("interpolate", True)
    loop = t.flag("loop", False)
    try:
        points = read_csv_points(path)
    except ConfigError as exc:
        raise t.fail("path", exc.message) from None
    return lambda origin: Schedule(points, origin, interpolate, loop)


#: How each model's table is read: its values checked, then a maker of the signal.
_MAKERS: dict[str, Callable[[Table], Callable[[float], Signal]]] = {
    "constant": _constant,
    "sine": _sine,
    "ramp": _ramp,
    "random_walk": _random_walk,
    "steps": _steps,
    "csv": _csv,
}
