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
        if not text:
            return False
        x = _PARSED.get(text)
        if x is None:
            try:
                x = Decimal(text)
            except ArithmeticError:
                return False
            if len(_PARSED) >= 4096:
                _PARSED.clear()
            _PARSED[text] = x
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


#: Texts of samples parsed lately (issue 24: a watched channel's texts repeat).
_PARSED: dict[str, Decimal] = {}
