"""A message sent when a channel crosses a value (§6.14.7), with hysteresis (§6.14.7.4).

The watcher remembers on which side of the value the channel was. While it is below, a
sample crosses upwards only when it exceeds ``value + h/2``; while it is above, a sample
crosses downwards only when it falls below ``value - h/2``. So a value wandering near the
threshold does not send a message at every sample. The first valid sample only tells the
side (at or below ``value`` counts as below); a sample without a valid value changes nothing.
Samples are compared as the channel shows them (in its format).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any, TypeVar

V = TypeVar("V", bound=Hashable)


@dataclass
class Crossing:
    """The side of one message's watched channel: None until the first valid sample."""

    function: str  # "UP" | "DOWN"
    value: Decimal
    hysteresis: Decimal
    above: bool | None = None
    #: :meth:`first_in`'s codes of values met, with what they depend on
    _codes: tuple[Hashable, dict[Any, int]] | None = field(default=None, repr=False, compare=False)

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
        code = self._coder()
        codes = {text: code(text) for text in set(texts)}
        return self._first([codes[text] for text in texts], texts.__getitem__)

    def first_in(self, values: list[V], text_of: Callable[[V], str], shown: Hashable) -> int | None:
        """:meth:`first_of` of the texts ``text_of`` renders ``values`` in, without rendering
        them: each value's code is kept from series to series (a watched channel's samples
        repeat: an ADC has 4096 levels) while ``shown`` (what the texts depend on besides the
        value: the channel's format), the value and the hysteresis stay."""
        key = (shown, self.value, self.hysteresis)
        if self._codes is None or self._codes[0] != key:
            self._codes = (key, {})
        codes: dict[V, int] = self._codes[1]
        try:
            got = list(map(codes.__getitem__, values))
        except KeyError:
            if len(codes) >= _CODES_MAX:
                codes.clear()
            code = self._coder()
            codes.update((v, code(text_of(v))) for v in set(values).difference(codes))
            got = list(map(codes.__getitem__, values))
        return self._first(got, lambda k: text_of(values[k]))

    def _coder(self) -> Callable[[str], int]:
        """A text's code: 0 no valid value, 1 above value + h/2 (crosses up), 2 below
        value - h/2 (crosses down), 3 both (a negative hysteresis), 4 neither."""
        half = self.hysteresis / 2
        high, low = self.value + half, self.value - half

        def code(text: str) -> int:
            x = _number(text)
            return 0 if x is None else (x > high) + 2 * (x < low) or 4

        return code

    def _first(self, got: list[int], text_at: Callable[[int], str]) -> int | None:
        """:meth:`first_of` of samples whose codes are ``got`` (``text_at``: the text of the
        sample at an index)."""
        first: int | None = None
        k = 0
        if self.above is None:  # (the first valid sample tells the side)
            k = next((k for k, c in enumerate(got) if c), -1)
            if k < 0:
                return None
            x = _number(text_at(k))
            assert x is not None
            self.above = x > self.value
            k += 1
        both = 3 in got
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


#: Values' codes kept by a crossing (:meth:`Crossing.first_in`) at most.
_CODES_MAX = 4096


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
