"""The expression evaluator: values against closed forms, undefined rows, and the grammar's limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gradekit.bank import expr


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("sind(30)", 0.49999999999999994),  # sin(pi/6) in binary
        ("cosd(60)", 0.5000000000000001),
        ("atan2d(1, 1)", 45.0),
        ("asind(0.5)", 30.000000000000004),
        ("hypot(3, 4)", 5.0),
        ("sqrt(2) ** 2", 2.0000000000000004),
        ("2 ** 10", 1024.0),
        ("-7 % 3", 2.0),  # Python's sign rule: the divisor's
        ("round(2.5) + round(3.5) + round(-0.4)", 6.0),  # half to even, and -0.4 rounds to 0
        ("min(3, 1, 2) + max(3, 1, 2)", 4.0),
        ("log10(1000) + exp(0)", 4.0),
        ("pi", math.pi),
        ("2 if 1 < 2 < 3 else 5", 2.0),
    ],
)
def test_values_are_the_closed_forms(text: str, value: float) -> None:
    assert expr.evaluate(text, {}) == value


def test_a_derived_parameter_is_what_python_floats_give_bit_for_bit() -> None:
    """The bank's derived values were Python's `**` and `math` before the evaluator was batched: a
    batch of many and a batch of one still give exactly those (``x ** 2`` is libm's pow, not
    ``x * x``, which differs in the last bit for about 1 in 1,000 values)."""
    rng = np.random.default_rng(3)
    ab, o2b = np.round(rng.uniform(3, 12, 2000), 3), np.round(rng.uniform(2, 8, 2000), 3)
    th = np.round(rng.uniform(0, 360, 2000), 1)
    text = "O2B*cosd(th2) - sqrt(max(AB**2 - (O2B*sind(th2))**2, 0)) + AB**2"
    many = expr.evaluate_many(text, {"AB": ab, "O2B": o2b, "th2": th})
    for a, o, t, m in zip(ab.tolist(), o2b.tolist(), th.tolist(), many.tolist(), strict=True):
        s = o * math.sin(math.radians(t))
        python = o * math.cos(math.radians(t)) - math.sqrt(max(a**2.0 - s**2.0, 0.0)) + a**2.0
        assert m == python
        assert expr.evaluate(text, {"AB": a, "O2B": o, "th2": t}) == python


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("sqrt(a)", "math domain error"),
        ("2 * sqrt(a) - 1", "math domain error"),
        ("1 / (a + 1)", "float division by zero"),
        ("5 % (a + 1)", "float modulo"),
        ("0 ** a", "0.0 cannot be raised to a negative power"),
        ("a ** 0.5", "the result is not a real number"),
        ("exp(-1000 * a)", "math range error"),
        ("log10(a + 1)", "math domain error"),
        ("10 ** (-400 * a / abs(a))", "(34, 'Numerical result out of range')"),
        ("2 ** (1000 - 1000 * a / abs(a))", "expected exponents of at most 1000, got 2000"),
        ("sqrt(a) > 1", "math domain error"),
    ],
)
def test_a_row_without_a_value_is_refused_with_its_reason(text: str, reason: str) -> None:
    env = {"a": np.array([-1.0, 4.0])}
    rows = expr.evaluate_rows(text, env)
    assert rows.undefined.tolist() == [True, False]
    assert rows.reason(0) == f"cannot evaluate {text!r}: {reason}" and rows.reason(1) == ""
    assert np.isnan(rows.value[0]) if rows.value.dtype == float else not rows.value[0]
    with pytest.raises(expr.ExprError) as err:
        expr.evaluate(text, {"a": -1.0})
    assert str(err.value) == f"cannot evaluate {text!r}: {reason}"
    expr.evaluate(text, {"a": 4.0})


def test_only_the_branch_a_row_takes_can_leave_it_undefined() -> None:
    a = np.array([-4.0, 4.0])
    assert expr.evaluate_many("sqrt(a) if a > 0 else -1", {"a": a}).tolist() == [-1.0, 2.0]
    assert expr.evaluate_many("a > 0 > sqrt(a)", {"a": a}).tolist() == [False, False]  # the chain stops at a > 0
    assert expr.evaluate_rows("a < 0 and sqrt(a) > 0", {"a": a}).undefined.tolist() == [True, False]
    assert expr.truth(expr.evaluate_many("not (sqrt(a) > 3)", {"a": a})).tolist() == [False, True]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("sqrt(a, b)", "expected sqrt with 1 argument, got 2 in 'sqrt(a, b)'"),
        ("round(a, 2)", "expected round with 1 argument, got 2 in 'round(a, 2)'"),
        ("atan2(a)", "expected atan2 with 2 arguments, got 1 in 'atan2(a)'"),
        ("min(a)", "expected min with two or more arguments, got 1 in 'min(a)'"),
        ("a // b", f"expected numbers, names, arithmetic and {', '.join(sorted(expr.FUNCTIONS))}; got // in 'a // b'"),
        ("9**9**9**9", "expected exponents of at most 1000, got a power tower in '9**9**9**9'"),
        ("a ** 2000", "expected exponents of at most 1000, got 2000 in 'a ** 2000'"),
    ],
)
def test_the_grammar_is_checked_before_anything_is_evaluated(text: str, message: str) -> None:
    with pytest.raises(expr.ExprError) as err:
        expr.parse(text)
    assert str(err.value) == message


def test_an_unknown_name_is_an_error_for_the_whole_batch() -> None:
    with pytest.raises(expr.ExprError, match=r"^unknown name 'x' in 'x \+ 1'$"):
        expr.evaluate_many("x + 1", {"a": np.zeros(3)})
