"""Chapter 5 (seed 000) bank problems: published versions, specific exact values, random variants."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gradekit import units
from gradekit.bank.schema import load_problem
from gradekit.sampling import variant

BANK = Path(__file__).resolve().parents[1] / "problem_bank"
FILES = {
    "ch5-ex5-2": "ch5_ex5_2_fourbar_superposition.yaml",
    "ch5-ex5-3": "ch5_ex5_3_fourbar_dynamic.yaml",
    "ch5-prob1": "ch5_prob1_offset_slider_crank.yaml",
    "ch5-prob2": "ch5_prob2_fourbar_two_forces.yaml",
    "ch5-prob3": "ch5_prob3_fourbar_pure_torques.yaml",
    "ch5-dyn-slider-crank": "ch5_dyn_slider_crank.yaml",
    "ch5-quiz-q1": "ch5_quiz_q1_fourbar_P_S.yaml",
    "ch5-quiz-q2": "ch5_quiz_q2_fourbar_inertia.yaml",
    "ch5-quiz-q3": "ch5_quiz_q3_slider_crank_rod_inertia.yaml",
    "ch5-quiz-q4": "ch5_quiz_q4_fourbar_rocker_inertia.yaml",
}
_CACHE: dict = {}


def problem(pid: str):
    if pid not in _CACHE:
        p = load_problem(BANK / FILES[pid])
        assert p.id == pid
        _CACHE[pid] = p
    return _CACHE[pid]


def published(pid: str) -> dict[str, float]:
    """Answers of the published variant, keyed as in the answer key."""
    v = variant(problem(pid))
    assert v.result.virtual_work_residual < 1e-9
    return {a.key: a.value for a in v.result.answers}


@pytest.mark.parametrize("pid", sorted(FILES))
def test_published_version_solves_and_matches_print(pid):
    p = problem(pid)
    v = variant(p)
    ans = {a.key: a for a in v.result.answers}
    assert v.result.virtual_work_residual < 1e-9
    assert all(math.isfinite(a.value) for a in ans.values())
    for pub in p.published:
        a = ans[pub.key]
        got = a.value if a.unit == "deg" else units.convert(a.value, a.unit, pub.unit)
        assert abs(got - pub.value) <= pub.rel * abs(pub.value), (pub.key, got, pub.value, pub.rel)


def test_ex5_2_exact_superposition():
    a = published("ch5-ex5-2")
    assert a["T_I"] == pytest.approx(-402.6, abs=0.1)     # N·mm, sub-problem I (F2 alone)
    assert a["T_II"] == pytest.approx(-449.4, abs=0.1)    # sub-problem II (F3 alone)
    assert a["T"] == pytest.approx(-852.0, abs=0.1)
    assert a["T"] == pytest.approx(a["T_I"] + a["T_II"], rel=1e-12)
    # the drawn torques (396, 442, 838 CW) are ~1.6 % low
    assert 0.012 < 1 - 838 / abs(a["T"]) < 0.02


def test_ex5_3_dynamic_fourbar():
    a = published("ch5-ex5-3")
    assert -853 < a["T"] < -850                            # N·mm, printed -851
    assert a["h2"] == pytest.approx(4.38, abs=0.01)       # mm (book 4.43 from rounded 208/47)
    assert a["h3"] == pytest.approx(9.13, abs=0.01)
    assert a["C2"] == pytest.approx(-206, abs=0.5)        # N·mm, CW
    assert a["C3"] == pytest.approx(274.6, abs=0.1)       # N·mm, CCW (needs I3 = 100 kg·mm²)
    assert a["aG2"] == pytest.approx(235150, rel=2e-4)
    assert a["alpha3"] == pytest.approx(-2746, abs=1)
    assert a["F01"] == pytest.approx(a["F12"], rel=1e-12)  # G1 at the crank pivot


def test_ex5_2_is_ex5_3_with_offset_forces():
    """Example 5.2's loads are 5.3's equivalent offset inertia forces: same torque to 0.05 %."""
    assert published("ch5-ex5-2")["T"] == pytest.approx(published("ch5-ex5-3")["T"], rel=5e-4)


def test_prob1_offset_slider_crank_by_power_balance():
    p = problem("ch5-prob1")
    vals = {n: q.value for n, q in p.parameters.items()}
    r, l, e, P = vals["r"], vals["l"], vals["e"], vals["P"]
    a = published("ch5-prob1")
    for case, phi in {"a": 45, "b": 135, "c": 270, "d": 315}.items():
        f = math.radians(phi)
        s = e - r * math.sin(f)
        dx = -r * math.sin(f) + s * r * math.cos(f) / math.sqrt(l * l - s * s)  # dx_C/dφ
        assert a[f"T_{case}"] == pytest.approx(P * dx, rel=1e-9)  # T + (-P)·dx/dφ = 0


def test_prob3_pure_torques_pass_one_force_through_every_pin():
    a = published("ch5-prob3")
    assert a["F12"] == pytest.approx(a["F23"], rel=1e-9) == a["F03"]
    assert a["T1"] == pytest.approx(a["T1_T2"] + a["T1_T3"], rel=1e-12)


def test_quiz_q3_derived_crank():
    v = variant(problem("ch5-quiz-q3"))
    assert v.result.values["r2"] == pytest.approx(1.858, abs=1e-9)   # O2A, in
    assert v.result.values["w2"] == pytest.approx(10.764, abs=1e-9)  # ω2 = 20 / 1.858
    a = {x.key: x.value for x in v.result.answers}
    assert a["w2"] == pytest.approx(10.764)
    assert a["FB_dir"] in (pytest.approx(90), pytest.approx(270))    # massless piston: vertical pin force
