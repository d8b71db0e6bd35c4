"""`csvsafe.safe_cell`'s short path for plain str, int and float cells gives what the general rule gives."""

from __future__ import annotations

from decimal import Decimal
from fractions import Fraction

import numpy as np
import pytest

from gradekit.csvsafe import safe_cell


class _Text(str):
    pass


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ("100017", "100017"),
        ("Student 17", "Student 17"),
        ("-1007", "-1007"),
        ("+2519", "+2519"),
        ("-1.5e3", "-1.5e3"),
        ("=1+2", "'=1+2"),
        ("-x", "'-x"),
        ("+", "'+"),
        ("@SUM(A1)", "'@SUM(A1)"),
        ("\t1", "'\t1"),
        ("\r=1", "'\r=1"),
        ("", ""),
        (_Text("=1+2"), "'=1+2"),
        (_Text("plain"), "plain"),
        (None, ""),
        (3 + 4j, "(3+4j)"),
    ],
)
def test_text_cells(value, expected):
    assert safe_cell(value) == expected
    assert type(safe_cell(value)) is str


@pytest.mark.parametrize("value", [3, -3, 0, 12.5, -0.0, float("inf"), True, np.float64(-1.5), np.int64(-7),
                                   Decimal("-2.5"), Fraction(-1, 3)])
def test_numbers_stay_the_same_objects(value):
    assert safe_cell(value) is value
