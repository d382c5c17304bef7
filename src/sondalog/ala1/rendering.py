"""A value's digits in a number format (§4.3.5) without the decimal context (issues 11, 24).

``NumberFormat.render(Decimal(repr(value)))`` rounds the shortest decimal that reads back as
the float, half away from zero, and never shows ``-0``. :func:`render` does the same with the
digits of the repr; :func:`fixed` by the float's own formatting where that provably gives the
same digits (averages rarely repeat, and the decimal rendering costs more than the rest of a
sample). tests/ala1/test_fast_sampling_render.py holds both to the Decimal rendering.
"""

from __future__ import annotations

from collections.abc import Sequence

#: ``y + HALF_EVEN - HALF_EVEN`` is ``round(y)`` as a float for any finite ``|y| < 2**51``:
#: the sum falls where floats are the whole numbers (1.5 * 2**52 .. 2**53), so the addition
#: rounds ``y`` to the nearest, ties to the even (IEEE 754's default; ``HALF_EVEN`` is even),
#: and the subtraction is exact. ``round()`` rounds alike to an int, which ``/`` turns into the
#: same float; here two float operations instead of a call (issue 24: a series' units in
#: :func:`~sondalog.ala1.measure.format_values`, the simulated inputs' columns).
HALF_EVEN = 6755399441055744.0  # 1.5 * 2**52


def fixed(value: float, decimals: int) -> str | None:
    """:func:`render` of ``repr(value)`` by ``format`` (issue 24: averages rarely repeat), or
    None where the two may differ. ``format`` rounds the float's exact binary value (half to
    even), :func:`render` the shortest decimal that reads back as it (half away from zero).
    Below ``10**(14 - decimals)`` no rounding boundary (a number with ``decimals + 1``
    decimals ending in 5) lies between the two unless the repr is that boundary itself, and
    then the value shown with one more decimal ends in 5: such values are left to
    :func:`render` (tests/ala1/test_fast_sampling_render.py). A value whose
    ``value * 10**decimals`` is computed within 1e-6 (below 2**33) and is farther than 1e-4
    from a half is far from every boundary."""
    size = abs(value)
    if size >= FIXED_BELOW[decimals] or (size < 1e-4 and value):
        return None  # (large, or a repr with an exponent)
    if size < NEAR_BELOW[decimals]:
        # Most values are far from a boundary (value * 10**decimals far from a half): the
        # nearest integer of the product is the rounding. Below 2**33 the product is off by
        # less than 1e-6, so is the repr.
        scaled = value * SCALES[decimals]
        if not 0.4999 < scaled % 1.0 < 0.5001:
            units = round(scaled)
            if not decimals:
                return str(units)
            digits = str(-units if units < 0 else units).rjust(decimals + 1, "0")
            text = f"{digits[:-decimals]}.{digits[-decimals:]}"
            return "-" + text if units < 0 else text
    finer, spec = FIXED_SPECS[decimals]
    if format(value, finer)[-1] == "5":
        return None
    text = format(value, spec)
    if text[0] == "-" and not text.strip("-0."):
        return text[1:]  # no "-0"
    return text


FIXED_BELOW = [10.0 ** (14 - decimals) for decimals in range(10)]
FIXED_SPECS = [(f".{decimals + 1}f", f".{decimals}f") for decimals in range(10)]
NEAR_BELOW = [2.0**33 / 10.0**decimals for decimals in range(10)]
SCALES = [10.0**decimals for decimals in range(10)]


def render(shown: str, decimals: int) -> str | None:
    """``NumberFormat.render(Decimal(shown))`` without the width, by the digits of the
    float's repr (issue 24: averages rarely repeat, and the decimal context costs more than
    the rest of a sample): round half away from zero, no ``-0``. None for an exponent."""
    if "e" in shown:
        return None
    negative = shown[0] == "-"
    whole, _, fraction = (shown[1:] if negative else shown).partition(".")
    if len(fraction) <= decimals:
        digits = whole + fraction + "0" * (decimals - len(fraction))
        number = int(digits)
    else:
        number = int(whole + fraction[:decimals])
        if fraction[decimals] >= "5":
            number += 1
        digits = str(number).rjust(decimals + 1, "0")
    if number == 0:
        negative = False
    else:
        digits = digits.lstrip("0").rjust(decimals + 1, "0")
    text = f"{digits[:-decimals]}.{digits[-decimals:]}" if decimals else digits
    return "-" + text if negative else text


def value_units(decimals: int, values: Sequence[float | None]) -> list[float | None]:
    """Each value's units of the last decimal (a whole float), or None where its text may
    show others: ``int`` of the digits of its text is its units (issue 24, seventh round)
    wherever ``value * 10**decimals`` is below 2**33 (computed within 1e-6, as is the repr)
    and farther than 1e-4 from a half, as in :func:`fixed` (a value near zero too: its repr
    may have an exponent, but it rounds to the same units)."""
    near, scale, rounds = NEAR_BELOW[decimals], SCALES[decimals], HALF_EVEN
    return [
        units
        if value is not None
        and -near < value < near
        and -0.4999 < (scaled := value * scale) - (units := scaled + rounds - rounds) < 0.4999
        else None
        for value in values
    ]
