"""A message sent when a channel crosses a value (§6.14.7), with hysteresis (§6.14.7.4).

The watcher remembers on which side of the value the channel was. While it is below, a
sample crosses upwards only when it exceeds ``value + h/2``; while it is above, a sample
crosses downwards only when it falls below ``value - h/2``. So a value wandering near the
threshold does not send a message at every sample. The first valid sample only tells the
side (at or below ``value`` counts as below); a sample without a valid value changes nothing.
Samples are compared as the channel shows them (in its format).
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal


@dataclass
class Crossing:
    """The side of one message's watched channel: None until the first valid sample."""

    function: str  # "UP" | "DOWN"
    value: Decimal
    hysteresis: Decimal
    above: bool | None = None

    def sample(self, text: str) -> bool:
        """A new sample (formatted; empty = no valid value); True when it triggers."""
        x = _number(text)
        if x is None:
            return False
        half = self.hysteresis / 2
        if self.above is None:
            self.above = x > self.value
            return False
        if not self.above and x > self.value + half:
            self.above = True
            return self.function == "UP"
        if self.above and x < self.value - half:
            self.above = False
            return self.function == "DOWN"
        return False

    def first_of(self, texts: list[str]) -> int | None:
        """:meth:`sample` of each of ``texts`` in order (issue 24: a series of samples): the
        index of the first that triggers (None: none does); the side ends as after the last.
        Each text is parsed once; the crossings are found by ``list.index``."""
        classes: dict[str, tuple[bool, bool, bool] | None] = {}
        half = self.hysteresis / 2
        high, low = self.value + half, self.value - half
        for text in set(texts):
            x = _number(text)
            classes[text] = None if x is None else (x > high, x < low, x > self.value)
        got = [classes[text] for text in texts]
        ups = [c is not None and c[0] for c in got]
        downs = [c is not None and c[1] for c in got]
        first: int | None = None
        k = 0
        if self.above is None:  # (the first valid sample tells the side)
            k = next((k for k, c in enumerate(got) if c is not None), -1)
            side = got[k] if k >= 0 else None
            if side is None:
                return None
            self.above = side[2]
            k += 1
        while True:
            wanted = downs if self.above else ups
            try:
                k = wanted.index(True, k)
            except ValueError:
                return first
            self.above = not self.above
            if first is None and self.function == ("UP" if self.above else "DOWN"):
                first = k
            k += 1


def _number(text: str) -> Decimal | None:
    """The number a sample shows (None: no valid value, or not a number)."""
    if not text:
        return None
    x = _PARSED.get(text)
    if x is None:
        try:
            x = Decimal(text)
        except ArithmeticError:
            return None
        if len(_PARSED) >= 4096:
            _PARSED.clear()
        _PARSED[text] = x
    return x


#: Texts of samples parsed lately (issue 24: a watched channel's texts repeat).
_PARSED: dict[str, Decimal] = {}
