"""Chapter 5 (seed 000) bank problems against independent formulations (moment equations, finite
differences, power balance, the printed data). The printed numbers themselves: test_bank_published."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import reference

from gradekit.bank.schema import load_problem
from gradekit.solving.pipeline import published_values
from gradekit.solving.sampling import variant

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


def _fourbar(a: dict) -> dict:
    """Points of the published four-bar (open: C above the frame line), mm."""
    return reference.fourbar_points(a["r1"], a["r2"], a["r3"], a["d"], math.radians(a["phi1"]))


def _toward(p, q, s):
    return p + s * (q - p) / np.hypot(*(q - p))


def test_ex5_2_against_moment_equations():
    """Every answer of Example 5.2 (graphical in the book) from the moment equations of each link."""
    p = problem("ch5-ex5-2")
    vals = published_values(p)
    pts = _fourbar(vals)
    f2 = [(_toward(pts["A"], pts["B"], vals["s2"]), reference.polar(vals["F2"], vals["th2"]), 0.0)]
    f3 = [(_toward(pts["O4"], pts["B"], vals["s3"]), reference.polar(vals["F3"], vals["th3"]), 0.0)]
    one, two, both = (reference.fourbar_statics(pts, coupler=c, rocker=r)
                      for c, r in ((f2, []), ([], f3), (f2, f3)))
    mag = np.hypot
    expect = {
        "T_I": one["T"], "F23_I": mag(*one["B"]), "F12_I": mag(*one["A"]),
        "T_II": two["T"], "F03_II": mag(*two["O4"]), "F23_II": mag(*two["B"]),
        "T": both["T"], "F01": mag(*both["O2"]), "F23": mag(*both["B"]), "F12": mag(*both["A"]),
        "F03": mag(*both["O4"]),
    }
    got = published("ch5-ex5-2")
    assert set(got) == set(expect)
    for key, value in expect.items():
        assert got[key] == pytest.approx(value, rel=1e-9), key
    assert got["T"] == pytest.approx(got["T_I"] + got["T_II"], rel=1e-12)  # superposition


def test_ex5_3_against_finite_differences_and_moment_equations():
    """Kinematics by central differences of circle-intersection positions; forces by moments."""
    p = problem("ch5-ex5-3")
    v = published_values(p)
    w = v["w1"]
    pos = reference.fourbar_positions(v["r1"], v["r2"], v["r3"], v["d"], {"coupler": v["r2"] / 2,
                                                                        "rocker": v["r3"] / 2})
    mo = reference.fd_motion(pos, math.radians(v["phi1"]), w, v["a1"])
    assert v["a1"] == 0  # G1 at the pivot and α1 = 0: the crank has no inertia load
    m = {"coupler": (v["m2"], v["I2"] * 1e-6), "rocker": (v["m3"], v["I3"] * 1e-6)}  # kg, kg·m²
    inertia = {b: (-m[b][0] * mo[b]["aG"] * 1e-3, -m[b][1] * mo[b]["alpha"] * 1e3) for b in m}  # N, N·mm
    pts = _fourbar(v)
    sol = reference.fourbar_statics(
        pts,
        coupler=[(mo["coupler"]["G"], *inertia["coupler"])],
        rocker=[(mo["rocker"]["G"], *inertia["rocker"])],
    )
    a = published("ch5-ex5-3")
    rel = 1e-6  # central differences with h = 1e-4 rad
    for key, body in (("aG2", "coupler"), ("aG3", "rocker")):
        assert a[key] == pytest.approx(np.hypot(*mo[body]["aG"]), rel=rel)
        assert a[key + "_dir"] == pytest.approx(reference.angle_deg(mo[body]["aG"]), abs=1e-4)
    assert a["alpha2"] == pytest.approx(mo["coupler"]["alpha"], rel=rel)
    assert a["alpha3"] == pytest.approx(mo["rocker"]["alpha"], rel=rel)
    assert a["Fi2"] == pytest.approx(np.hypot(*inertia["coupler"][0]), rel=rel)
    assert a["Fi3"] == pytest.approx(np.hypot(*inertia["rocker"][0]), rel=rel)
    assert a["C2"] == pytest.approx(inertia["coupler"][1], rel=rel)
    assert a["C3"] == pytest.approx(inertia["rocker"][1], rel=rel)
    for key, body in (("h2", "coupler"), ("h3", "rocker")):  # h = |C| / |F|
        assert a[key] == pytest.approx(abs(inertia[body][1]) / np.hypot(*inertia[body][0]), rel=rel)
    assert a["T"] == pytest.approx(sol["T"], rel=rel)
    for key, pin in (("F23", "B"), ("F12", "A"), ("F03", "O4"), ("F01", "O2")):
        assert a[key] == pytest.approx(np.hypot(*sol[pin]), rel=rel), key


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
    """O2A and ω2 follow from the quiz's printed data (AB = 4, O2B = 5.5 in, V_A = 20 in/s) at
    θ2 = 30°: the shorter root of triangle O2AB, each rounded to the 3 decimals printed."""
    v = variant(problem("ch5-quiz-q3"))
    th = math.radians(30)
    r2 = round(5.5 * math.cos(th) - math.sqrt(4**2 - (5.5 * math.sin(th)) ** 2), 3)
    assert v.result.values["r2"] == pytest.approx(r2, abs=1e-12)
    assert v.result.values["w2"] == pytest.approx(round(20 / r2, 3), abs=1e-12)
    a = {x.key: x.value for x in v.result.answers}
    assert a["w2"] == pytest.approx(round(20 / r2, 3), rel=1e-12)
    assert a["FB_dir"] % 180 == pytest.approx(90, abs=1e-9)  # massless piston: vertical pin force
