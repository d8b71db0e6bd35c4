"""A unit's powers: small exponents as engineers write them pass; a tower of powers, which pint
would evaluate as a number (9^9^9 has 369 million digits and hung a grading batch), is refused as
bad input, at once."""

from __future__ import annotations

import pytest

from gradekit import units
from gradekit.errors import GradekitError


@pytest.mark.parametrize("unit", ["9^9^9", "m^99^99", "9**9**9", "(m**9)**9**9", "m**12", "s^-12",
                                  "m**2*m**2*m**2*m**2"])
def test_powers_that_are_not_a_unit_are_refused(unit):
    with pytest.raises(GradekitError, match="expected a unit such as"):
        units.factor(unit, "N*m")


@pytest.mark.parametrize("unit, to, expected", [
    ("kg*m**2/s**2", "N*m", 1.0), ("m/s^2", "mm/s**2", 1000.0), ("s^-1", "1/s", 1.0), ("mm²", "m**2", 1e-6),
    ("kg·mm²", "kg*m**2", 1e-6), ("rad/s2", "rad/s**2", 1.0), ("m ** 2", "mm**2", 1e6),
    ("m**0.5", "mm**0.5", 1000**0.5),
])
def test_powers_engineers_write_still_convert(unit, to, expected):
    assert units.factor(unit, to) == pytest.approx(expected, rel=1e-12)
