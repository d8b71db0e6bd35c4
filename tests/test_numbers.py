"""The one number formatter against an independent rule: the exact binary value rounded half-even to
the asked significant figures (Python's decimal module), printed without exponent or trailing zeros."""

from __future__ import annotations

import random
from decimal import ROUND_HALF_EVEN, Decimal

import pytest

from gradekit.numbers import fmt


def reference(value: float, sig: int) -> str:
    d = Decimal(value)  # exact
    if d == 0:
        return "0"
    step = Decimal(1).scaleb(d.adjusted() - sig + 1)
    text = format(d.quantize(step, rounding=ROUND_HALF_EVEN), "f")
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if Decimal(text) == 0 else text


@pytest.mark.parametrize("sig", [3, 4, 5, 6])
def test_fmt_rounds_to_significant_figures_as_decimal_does(sig):
    rng = random.Random(sig)
    values = [rng.choice((1, -1)) * 10 ** rng.uniform(-7, 8) for _ in range(20_000)]
    values += [float(f"{v:.{rng.randint(1, 7)}g}") for v in values[:5_000]]  # short decimals and ties
    values += [2.5, 0.125, 99999.5, 9.99995, 1000.0, -0.0043, 235150.0, 1.1184]
    for v in values:
        assert fmt(v, sig) == reference(v, sig), (v, sig)
