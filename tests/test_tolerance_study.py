"""The tolerance study scores with the grader's own rule.

The study (benchmarks/tolerance_study.py) judges every simulated answer with
`Tolerance.accepts_many(answers, values, scales)`; the grader judges one student's answer with
the `Tolerance` of that student's key (`Result.answers[k].tolerance`, its floor resolved for the
variant) through `Tolerance.accepts`. These tests check on bank variants that the two accept and
reject the same answers: at the band's edges, across 0°/360° and near the floor.
"""

from __future__ import annotations

import numpy as np
import pytest

from gradekit.bank.registry import load_bank
from gradekit.solving.keys import Tolerance
from gradekit.solving.sampling import sample_many

BANK = load_bank()
# a problem with angle answers, one with small components judged by the floor, one graphical
PROBLEMS = ("ch5-ex5-3", "s004-case-study", "ch5-quiz-q2", "s002-fourbar-matrix")


def probes(value: float, band: float, period: float, rng: np.random.Generator) -> list[float]:
    """Answers around *value*: just inside and outside the band, wrapped by a period, random."""
    out = [value]
    for k in (0.5, 0.999999, 1.000001, 1.5, 3.0):
        out += [value + k * band, value - k * band]
    if period:
        out += [x + s * period for x in out[:11] for s in (1, -1)]
        out += [(value + 0.999 * band) % period, (value - 0.999 * band) % period]
    out += list(value + rng.normal(0, 2 * band + 1e-12, 6))
    return out


@pytest.mark.parametrize("pid", PROBLEMS)
def test_study_acceptance_agrees_with_the_grader(pid):
    p = BANK[pid]
    vb = sample_many(p, range(25))
    rng = np.random.default_rng(5)
    seen_floor = seen_wrap = 0
    for i in np.flatnonzero(vb.ok)[:25]:
        v = vb.variant(int(i))
        batch, j = v.batch, v.index
        for ab, key in zip(batch.answer_list, v.result.answers, strict=True):
            value, scale = float(ab.value[j]), float(ab.scale[j])
            graded = key.tolerance  # the student's key: floor resolved for this variant
            band = graded.band(value)
            xs = np.array(probes(value, band, graded.period, rng))
            study = ab.spec.tolerance.accepts_many(xs, np.full(xs.size, value), np.full(xs.size, scale))
            grader = np.array([graded.accepts(float(x), value) for x in xs])
            assert (study == grader).all(), (pid, ab.key, value, scale, xs[study != grader])
            seen_floor += bool(ab.spec.tolerance.floor and graded.abs > ab.spec.tolerance.rel * abs(value))
            seen_wrap += bool(graded.period) and bool(grader[xs > 360].any() or grader[xs < 0].any())
    assert seen_floor or pid == "ch5-quiz-q2"  # answers whose band is the floor were probed
    if pid in ("ch5-ex5-3", "ch5-quiz-q2"):
        assert seen_wrap  # an answer across 0°/360° was accepted by both


def test_angles_across_zero_and_floors_agree_elementwise():
    ang = Tolerance("relative", 0.0, 2.0, period=360.0)
    values = np.array([359.5, 0.5, 180.0, 359.9, 0.0])
    answers = np.array([1.0, 359.0, 182.5, -0.5, 362.0])
    many = ang.accepts_many(answers, values, np.zeros(5))
    assert list(many) == [ang.accepts(a, v) for a, v in zip(answers, values, strict=True)]
    assert list(many) == [True, True, False, True, True]
    flo = Tolerance("relative", 0.01, 0.0, floor=0.03)
    values = np.array([0.5, -2.0, 100.0, 0.0])
    scales = np.array([200.0, 200.0, 200.0, 50.0])
    answers = np.array([6.4, -8.1, 106.1, -1.5])
    many = flo.accepts_many(answers, values, scales)
    one = [flo.resolve(s).accepts(a, v) for a, v, s in zip(answers, values, scales, strict=True)]
    assert list(many) == one == [True, False, False, True]
    assert not flo.accepts_many(np.array([np.nan, np.inf]), np.array([1.0, 1.0]), np.array([1.0, 1.0])).any()
