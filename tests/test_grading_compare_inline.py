"""`compare` and the diagnosis inline `Tolerance.band` and `Tolerance.accepts` for relative tolerances:
held to the methods on values at, inside and outside the band's edge, zero, NaN and infinities."""

from __future__ import annotations

import math
import random

import pytest

from gradekit.grading.compare import METHOD_MISTAKES, _diagnoses, _generic, compare
from gradekit.grading.reader import Answer
from gradekit.keys import KeyEntry, Mistake, Tolerance

TOLERANCES = [
    Tolerance("relative", 0.01),
    Tolerance("relative", 0.02, abs=0.5),
    Tolerance("relative", 0.0, abs=1.0, period=360.0),
    Tolerance("sigfigs", 0.0, sigfigs=3),
    Tolerance("sigfigs", 0.01, abs=0.05, sigfigs=2),
]


def _values(rng: random.Random, key: float, tol: Tolerance) -> list[float]:
    band = tol.band(key)
    edge = [key + band, key - band, key + band * (1 + 1e-12), key + band * (1 + 2e-12), key - band * (1 + 3e-12)]
    return [*edge, key, -key, 0.0, key * 1000, key * rng.uniform(0.9, 1.1), math.inf, -math.inf, math.nan]


def _reference(entry: KeyEntry, value: float) -> tuple[Mistake | None, Mistake | None]:
    """The diagnosis as specified: the entry's mistakes in order, then the generic ones, by `accepts`."""
    accepts = entry.tolerance.accepts
    fits = [m for m in entry.mistakes if math.isfinite(m.value) and accepts(value, m.value)]
    if fits:
        return fits[0], next((m for m in fits if m.name in METHOD_MISTAKES), None)
    named = {m.name for m in entry.mistakes}
    for name, description, v in _generic(entry):
        if name not in named and math.isfinite(v) and accepts(value, v):
            return Mistake(name, description, v), None
    return None, None


@pytest.mark.parametrize("tol", TOLERANCES, ids=lambda t: f"{t.mode}-{t.rel}-{t.abs}-{t.period}")
def test_the_verdict_and_diagnosis_equal_the_tolerances_own_predicate(tol):
    rng = random.Random(7)
    for key in (0.0, 1e-9, 0.37, 12.5, -40.77, 359.9, 2.5e6, rng.uniform(-100, 100)):
        static = key * rng.uniform(0.5, 0.99)
        mistakes = (Mistake("sign flipped", "s", -key), Mistake("static-answer", "a static answer", static),
                    Mistake("no-gravity", "g", static), Mistake("nan", "n", math.nan))
        entry = KeyEntry("1", "p1", "p1.x", key, "N", tol, 1.0, mistakes=mistakes)
        bare = KeyEntry("1", "p1", "p1.x", key, "N", tol, 1.0)
        for value in _values(rng, key, tol) + _values(rng, static, tol):
            result = compare(entry, Answer("p1.x", repr(value), "", value, "", 2, "value", ""))
            assert result.correct == tol.accepts(value, key), (key, value)
            assert _diagnoses(entry, value) == _reference(entry, value), (key, value)
            assert _diagnoses(bare, value) == _reference(bare, value), (key, value)


def test_a_value_at_the_edge_of_a_relative_band():
    tol = Tolerance("relative", 0.01, abs=0.5)  # band of 200 is 2.0; of 20 the floor 0.5
    entry = KeyEntry("1", "p1", "p1.x", 200.0, "N", tol, 1.0, mistakes=(Mistake("static-answer", "s", 20.0),))
    ok = compare(entry, Answer("p1.x", "202", "", 202.0, "", 2, "value", ""))
    assert ok.correct and ok.points == 1.0
    wrong = compare(entry, Answer("p1.x", "202.01", "", 202.01, "", 2, "value", ""))
    assert not wrong.correct and wrong.diagnosis is None
    static = compare(entry, Answer("p1.x", "20.5", "", 20.5, "", 2, "value", ""))
    assert static.diagnosis == static.method_diagnosis == Mistake("static-answer", "s", 20.0)
    assert compare(entry, Answer("p1.x", "20.51", "", 20.51, "", 2, "value", "")).diagnosis is None
