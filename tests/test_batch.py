"""The batched core: identical answers to the pre-batch solver, refusals per variant, exact bounds."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from gradekit.bank.registry import load_bank
from gradekit.mechanics.forces import Conditioning, solve, solve_many
from gradekit.mechanics.mechanisms import Motion, build, build_many
from gradekit.mechanics.model import Analysis, Load
from gradekit.solving.pipeline import published_values, solve_problem
from gradekit.solving.pipeline import solve_many as solve_problem_many
from gradekit.solving.sampling import sample_many, variant

GOLDEN = json.loads((Path(__file__).parent / "data" / "golden_answers.json").read_text())
BANK = load_bank()


@pytest.mark.parametrize("pid", sorted(GOLDEN["problems"]))
def test_every_answer_is_what_the_one_at_a_time_solver_gave(pid):
    """tests/data/golden_answers.json holds the published and five students' variants of every
    problem as the scalar solver drew and solved them before the re-cut (its commit is in the
    file): the batched solver gives the same answers at the same values, to roundoff. (Which values a
    student draws changed with the bank's gradability rule of issue 25; the published values and the
    draws of a seed are pinned in tests/test_sampling.py.)"""
    p = BANK[pid]
    for who, rec in GOLDEN["problems"][pid].items():
        if who == "published":
            assert variant(p).values == rec["values"]
        got = {a.key: (a.value, a.unit) for a in solve_problem(p, rec["values"]).answers}
        for key, (value, unit) in rec["answers"].items():
            if key not in got:  # an answer the bank no longer asks
                continue
            assert got[key][1] == unit
            assert got[key][0] == pytest.approx(value, rel=1e-12, abs=1e-300), (who, key)


@pytest.mark.parametrize("pid", sorted(BANK))
def test_a_batch_gives_each_variant_what_it_gives_alone(pid):
    p = BANK[pid]
    vb = sample_many(p, range(12))
    answers = vb.answers
    for i in range(len(vb)):
        alone = solve_problem(p, {k: float(v[i]) for k, v in vb.values.items()})
        for a in alone.answers:
            assert answers[a.key][i] == pytest.approx(a.value, rel=1e-12, abs=1e-12 * max(1.0, abs(a.value)))


def test_refused_variants_are_masked_with_their_reason_and_do_not_disturb_the_others():
    crank = np.array([0.03, 0.2, 0.03, 0.03])  # 0.2 cannot close a 0.1/0.05/0.07 loop
    link = build_many(
        "fourbar", {"crank": crank, "coupler": 0.1, "rocker": 0.05, "frame": 0.07}, Motion(np.radians(135), 95.0)
    )
    assert list(link.refused.mask) == [False, True, False, False]
    assert "coupler AB and rocker O4B" in link.refused.reason(1) and "100 mm" in link.refused.reason(1)
    an = Analysis(loads=(Load("P", "rocker", (0.0, -10.0), 0.0, "", 0.025),))
    sols = solve_many(link, an)
    assert list(sols.ok) == [True, False, True, True]
    params = {"crank": 0.03, "coupler": 0.1, "rocker": 0.05, "frame": 0.07}
    alone = solve(build("fourbar", params, Motion(np.radians(135), 95.0)), an)
    assert sols.driver[0] == pytest.approx(alone.driver, rel=1e-14)
    assert sols.driver[3] == pytest.approx(alone.driver, rel=1e-14)


def test_condition_bounds_decide_like_the_svd():
    """κ_F/n ≤ κ₂ ≤ κ_F: deciding "above the limit" by the bounds, with an SVD where they straddle
    it, matches numpy's 2-norm condition number on every matrix, near-singular ones included."""
    rng = np.random.default_rng(7)
    n = 400
    a = rng.normal(size=(n, 6, 6))
    a[::3, :, 0] = a[::3, :, 1] * (1 + 10.0 ** rng.uniform(-9, -2, size=(len(a[::3]), 1)))
    exact = np.linalg.cond(a)
    assert (exact > 1e12).any()  # numerically singular ones too: no inverse, so no bound, an SVD decides
    inv = np.array([np.linalg.inv(x) if k < 1e12 else np.full(x.shape, np.nan) for x, k in zip(a, exact, strict=True)])
    refused = np.zeros(n, bool)
    for limit in (10.0, 1e3, 1e7):
        c = Conditioning(a, refused, inv)
        assert np.array_equal(c.above(limit), exact > limit)
        if limit == 1e7:  # far above the typical κ (the refusal bound): the bounds alone decide most
            assert np.isnan(c._exact).mean() > 0.5
    c = Conditioning(a, refused, inv)
    assert np.array_equal(c.values, exact)


def test_condition_of_scaled_systems_is_that_of_the_systems_formed():
    """Given a, the row and column scales and a⁻¹·diag(rows)⁻¹ (what the solver's one solve gives), the
    bounds and the exact κ are those of S = diag(rows)·a·diag(cols) formed in full (numpy's SVD)."""
    rng = np.random.default_rng(11)
    n = 300
    a = rng.normal(size=(n, 5, 5))
    near = a[::4]  # nearly singular: a column within 1e-7 to 1e-2 of another
    near[:, :, 0] = near[:, :, 1] + 10.0 ** rng.uniform(-7, -2, size=(len(near), 1)) * rng.normal(size=(len(near), 5))
    a[::4] = near
    rows, cols = 10.0 ** rng.uniform(-3, 3, size=(n, 5)), 10.0 ** rng.uniform(-3, 3, size=(n, 5))
    s = rows[:, :, None] * a * cols[:, None, :]
    exact = np.linalg.cond(s)
    inv = np.linalg.inv(a) / rows[:, None, :]  # a⁻¹·R⁻¹
    refused = np.zeros(n, bool)
    refused[5] = True
    for limit in (1e2, 1e5, 1e9):
        c = Conditioning(a, refused, inv, rows, cols)
        assert np.array_equal(c.above(limit), (exact > limit) | refused)
        sound = ~refused & (exact < 1e10)  # beyond, the SVD's own κ is off by more than the bounds' slack
        assert np.all(c.lower[sound] <= exact[sound]) and np.all(exact[sound] <= c.upper[sound])
    frobenius = np.linalg.norm(s, axis=(1, 2)) * np.linalg.norm(np.linalg.inv(s), axis=(1, 2))
    well = ~refused & (exact < 1e10)
    assert np.allclose(c.upper[well], frobenius[well], rtol=1e-6)
    c = Conditioning(a, refused, inv, rows, cols)
    assert np.allclose(c.values[~refused], exact[~refused], rtol=1e-12) and c.values[5] == np.inf
    sel = np.arange(n) % 3 == 0
    assert np.allclose(c.take(sel).values[~refused[sel]], exact[sel][~refused[sel]], rtol=1e-12)


def test_a_full_crank_cycle_in_one_batch_does_no_net_work():
    """With constant speed and constant loads, the driver's work over a whole turn balances the
    change of kinetic energy and the loads' work, both zero for a periodic motion: the mean drive
    torque over 360 positions solved in one batch is zero (the trapezoid rule is exact to roundoff
    for a smooth periodic function), while the torque itself is far from zero."""
    p = BANK["ch5-dyn-slider-crank"]
    theta = p.inputs["theta"]
    base = published_values(p)
    unit = p.parameters[theta].unit
    turn = 360.0 if unit == "deg" else 2 * math.pi
    angles = np.arange(360) * turn / 360
    batch = solve_problem_many(dataclasses.replace(p, cases={}), {**base, theta: angles}, 360)
    assert batch.ok.all()
    torque, _ = batch.cases[0].results["driver"]
    assert np.abs(torque).max() > 0
    assert abs(torque.mean()) < 1e-9 * np.abs(torque).max()
    assert (batch.virtual_work_residual < 1e-9).all()
