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
        half = self.hysteresis / 2
        high, low = self.value + half, self.value - half
        # each text's code: 0 no valid value, 1 above value + h/2 (crosses up), 2 below
        # value - h/2 (crosses down), 3 both (a negative hysteresis), 4 neither
        codes: dict[str, int] = {}
        for text in set(texts):
            x = _number(text)
            codes[text] = 0 if x is None else (x > high) + 2 * (x < low) or 4
        got = [codes[text] for text in texts]
        first: int | None = None
        k = 0
        if self.above is None:  # (the first valid sample tells the side)
            k = next((k for k, c in enumerate(got) if c), -1)
            if k < 0:
                return None
            x = _number(texts[k])
            assert x is not None
            self.above = x > self.value
            k += 1
        both = 3 in codes.values()
        while True:
            try:
                if both:
                    wanted = (2, 3) if self.above else (1, 3)
                    k = next(j for j in range(k, len(got)) if got[j] in wanted)
                else:
                    k = got.index(2 if self.above else 1, k)
            except (ValueError, StopIteration):
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
