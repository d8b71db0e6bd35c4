"""The solver at the extremes: accurate against an independent formulation, or a clear refusal."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from gradekit.errors import ConditioningError, GeometryError
from gradekit.mechanics.mechanisms import Motion
from gradekit.mechanics.model import Analysis, Load

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import stability as st  # noqa: E402


@pytest.mark.parametrize("theta_deg", [0.1, 0.01, 1e-4, 0.0, 179.9, 179.99, 180.0])
def test_slider_crank_dead_centres_match_closed_form(theta_deg):
    r, l_, push = 0.03, 0.07, 40.0
    th = math.radians(theta_deg)
    t, cond, _ = st.solver_driver("slider_crank", {"crank": r, "rod": l_}, Motion(th), st.slider_static(r, l_, push))
    assert abs(t - st.slider_closed_form(r, l_, th, push)) <= 1e-12 * push * r
    assert cond < 10  # a torque-driven slider crank is well conditioned at its dead centres


def test_slider_crank_example_5_1_value():
    t, _, _ = st.solver_driver(
        "slider_crank", {"crank": 0.03, "rod": 0.07}, Motion(math.radians(45)), st.slider_static(0.03, 0.07, 40.0)
    )
    assert t == pytest.approx(-1.118, abs=5e-4)  # NOTES.md: exact −1.118 N·m


def test_fourbar_toggle_error_grows_with_condition_then_refuses():
    rows = st.fourbar_toggle((1.0, 1e-2, 1e-4, 1e-6, 1e-8, 1e-12, 0.0))
    solved = [r for r in rows if not r["refusal"]]
    assert len(solved) == 5
    mus = [r["mu_deg"] for r in solved]
    conds = [r["cond"] for r in solved]
    assert mus == sorted(mus, reverse=True) and conds == sorted(conds)
    for r in solved:  # backward stable: error ≲ cond × machine epsilon × a small factor
        assert r["err_vs_moments"] <= 1e-13 * r["cond"]
        assert r["cond"] * math.radians(r["mu_deg"]) == pytest.approx(solved[0]["cond"] * math.radians(mus[0]), rel=0.6)
    assert solved[0]["fd_vs_moments"] < 1e-5  # the finite-difference formulation agrees away from toggle
    assert "condition number" in rows[-2]["refusal"] and "toggle" in rows[-2]["refusal"]
    assert rows[-1]["refusal"].startswith("GeometryError") and "toggle" in rows[-1]["refusal"]


def test_fourbar_toggle_refusal_is_a_conditioning_error():
    th = st.toggle_angle() + math.radians(1e-12)
    an = Analysis(False, None, {}, (Load("F", "rocker", (30.0, -20.0), 0.0, "", 0.04),))
    with pytest.raises(ConditioningError, match="condition number"):
        st.solver_driver("fourbar", st.FOURBAR, Motion(th), an)
    with pytest.raises(GeometryError, match="toggle|assembled"):
        st.solver_driver("fourbar", st.FOURBAR, Motion(st.toggle_angle() - math.radians(1e-3)), an)


def test_link_ratios_to_one_in_a_thousand():
    for r in st.link_ratios((1.0, 10.0, 1000.0)):
        assert not r["refusal"] and r["err"] < 1e-13 and r["cond"] < 20


@pytest.mark.parametrize("omega", [1.0, 100.0, 1e4])
def test_speeds_against_finite_differences(omega):
    m = Motion(math.radians(45.0), omega, omega * omega / 10)
    an = st.dynamic_slider()
    t, _, _ = st.solver_driver("slider_crank", st.EX36, m, an)
    assert t == pytest.approx(st.fd_driver("slider_crank", st.EX36, m, an), rel=1e-6)


@pytest.mark.parametrize("mass", [1e-6, 1.0, 1e3])
def test_masses_against_finite_differences(mass):
    m = Motion(math.radians(45.0), 100.0, 0.0)
    an = st.dynamic_slider(mass)
    t, _, _ = st.solver_driver("slider_crank", st.EX36, m, an)
    assert t == pytest.approx(st.fd_driver("slider_crank", st.EX36, m, an), rel=1e-6)


def test_unit_systems_and_scale_agree():
    rows = st.unit_systems()
    assert {r["system"] for r in rows} >= {"mm, N", "m, N", "in, lbf"}
    for r in rows:
        assert r["err"] < 1e-13 and r["T_Nm"] == pytest.approx(-1.118, abs=5e-4)
    assert len({round(r["cond"], 9) for r in rows}) == 1  # the condition number is unit-free
