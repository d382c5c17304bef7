"""Regular sampling instants and clamped walks over many steps (issue 24).

Helpers of :mod:`sondalog.backends.sim.signals` for the series path, which reads a signal at
a whole stretch of sampling instants at once: whether the instants step by whole intervals of
a random walk (then its steps are a slice), and a clamped walk summed many steps at a time.
Both give the very floats of the step-by-step computation.
"""

from __future__ import annotations

import itertools
import operator

#: Steps of a clamped random walk summed at once, unless one of them is clamped.
RUN = 64


def stride_of(times: list[float], zero: float, interval: float) -> int:
    """How many intervals the ``times`` step by, when every ``(t - zero) // interval`` is
    exact (whole numbers of seconds well within a float's precision, positive times) and
    each is the one before plus the stride; else 0."""
    if len(times) < 3:
        return 0
    interval, zero = float(interval), float(zero)
    step, first, last = times[1] - times[0], times[0], times[-1]
    try:
        if not (first > 0 and last < _EXACT and abs(zero) < _EXACT and step > 0 and interval > 0):
            return 0
        stride = step / interval
        if not all(map(float.is_integer, (interval, zero, step, stride, *times))):
            return 0  # (then the differences of the times are exact)
    except TypeError:  # (a time that is not a float)
        return 0
    if not all(map(operator.eq, map(operator.sub, times[1:], times[:-1]), itertools.repeat(step))):
        return 0
    return int(stride)


#: Whole numbers up to here are floats with room: sums and differences of them are exact.
_EXACT = 2.0**50


def walk_clamped(values: list[float], moves: list[float], lo: float, hi: float) -> None:
    """Append to ``values`` each step of a walk from its last value: ``min(max(last + move,
    lo), hi)`` written out. A run of steps none of which leaves ``[lo, hi]`` is the running
    sum of its moves, summed in C (the same floats, added in the same order)."""
    last = values[-1]
    append = values.append
    for k in range(0, len(moves), RUN):
        run = moves[k : k + RUN]
        walked = list(itertools.accumulate(run, operator.add, initial=last))
        if lo <= min(walked) and max(walked) <= hi:  # (nothing clamped: the sums)
            values += walked[1:]
            last = walked[-1]
            continue
        for move in run:
            v = last + move
            v = lo if lo > v else v
            last = hi if hi < v else v
            append(last)
