"""The solver at the extremes: accurate against an independent formulation, or a clear refusal.

References (tests/reference.py): the slider crank's closed form, the four-bar's moment equations,
and the power balance with finite-difference velocity ratios of closed-form positions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import reference

from gradekit import units
from gradekit.mechanics.forces import solve
from gradekit.mechanics.mechanisms import Motion, build
from gradekit.mechanics.model import Analysis, Load, MassProps

try:
    from gradekit.mechanics.errors import ConditioningError, GeometryError
except ImportError:  # before the numeric core had its own errors
    from gradekit.errors import ConditioningError, GeometryError

FOURBAR = {"crank": 0.03, "coupler": 0.10, "rocker": 0.05, "frame": 0.07}  # Example 5.3, non-Grashof
ROCKER_LOAD = ((30.0, -20.0), 0.04)  # N on the rocker, 40 mm from O4


def slider_static(push: float) -> Analysis:
    return Analysis(loads=(Load("P", "slider", (-push, 0.0)),))


def driven(kind: str, p: dict, m: Motion, an: Analysis):
    """(solution, linkage) of *kind* at motion *m*; raises the solver's own errors."""
    link = build(kind, p, m)
    return solve(link, an), link


def toggle_angle(p: dict = FOURBAR) -> float:
    """Crank angle where coupler and rocker fold onto one line (|A − O4| = coupler − rocker)."""
    r, d, k = p["crank"], p["frame"], p["coupler"] - p["rocker"]
    return math.acos((r * r + d * d - k * k) / (2 * r * d))


def fourbar_moments(link, force=ROCKER_LOAD[0], along=ROCKER_LOAD[1]) -> float:
    """Crank torque by the moment equations of each link, at the linkage's own points."""
    pts = {k: np.asarray(link.points[k].pos(), dtype=float) for k in ("O2", "A", "B", "O4")}
    u = (pts["B"] - pts["O4"]) / np.hypot(*(pts["B"] - pts["O4"]))
    return reference.fourbar_statics(pts, rocker=[(pts["O4"] + along * u, np.asarray(force), 0.0)])["T"]


def fourbar_rocker_load() -> Analysis:
    return Analysis(loads=(Load("F", "rocker", ROCKER_LOAD[0], 0.0, "", ROCKER_LOAD[1]),))


@pytest.mark.parametrize("theta_deg", [0.1, 0.01, 1e-4, 0.0, 179.9, 179.99, 180.0])
def test_slider_crank_dead_centres_match_closed_form(theta_deg):
    r, l_, push = 0.03, 0.07, 40.0
    th = math.radians(theta_deg)
    sol, _ = driven("slider_crank", {"crank": r, "rod": l_}, Motion(th, 1.0), slider_static(push))
    assert abs(sol.driver - reference.slider_static(r, l_, th, push)["T"]) <= 1e-12 * push * r
    assert sol.condition_number < 10  # a torque-driven slider crank is well conditioned at its dead centres


def test_fourbar_toggle_error_grows_with_condition_then_refuses():
    th0 = toggle_angle()
    rows = []
    for delta in (1.0, 1e-2, 1e-4, 1e-6, 1e-8):
        sol, link = driven("fourbar", FOURBAR, Motion(th0 + math.radians(delta), 1.0), fourbar_rocker_load())
        ref = fourbar_moments(link)
        rows.append((link.transmission, sol.condition_number, abs(sol.driver - ref) / abs(ref)))
    mus, conds = [r[0] for r in rows], [r[1] for r in rows]
    assert mus == sorted(mus, reverse=True) and conds == sorted(conds)
    for mu, cond, err in rows:  # backward stable: error ≲ cond × machine epsilon × a small factor
        assert err <= 1e-13 * cond
        assert cond * math.radians(mu) == pytest.approx(conds[0] * math.radians(mus[0]), rel=0.6)  # cond ∝ 1/μ
    with pytest.raises(ConditioningError, match="condition number"):
        driven("fourbar", FOURBAR, Motion(th0 + math.radians(1e-12), 1.0), fourbar_rocker_load())
    with pytest.raises(GeometryError, match="toggle|assembled"):
        driven("fourbar", FOURBAR, Motion(th0 - math.radians(1e-3), 1.0), fourbar_rocker_load())


def test_link_ratios_to_one_in_a_thousand():
    th, push = math.radians(45.0), 40.0
    for ratio in (1.0, 10.0, 1000.0):  # slider crank, rod/crank from 1:1 to 1000:1
        r, l_ = 0.03, 0.03 * ratio
        sol, _ = driven("slider_crank", {"crank": r, "rod": l_}, Motion(th, 1.0), slider_static(push))
        ref = reference.slider_static(r, l_, th, push)["T"]
        assert abs(sol.driver - ref) / abs(ref) < 1e-13 and sol.condition_number < 20
    for scale in (1.0, 0.1, 0.01, 0.001):  # four-bar, crank/coupler to 1:3000
        p = dict(FOURBAR, crank=0.03 * scale)
        sol, link = driven("fourbar", p, Motion(math.radians(135), 1.0), fourbar_rocker_load())
        ref = fourbar_moments(link)
        assert abs(sol.driver - ref) / abs(ref) < 1e-13 and sol.condition_number < 20


# Worked Example III.6's slider crank (AB = 80, BC = 240, G1 at mid-crank, BG = 120 mm) with gravity
# and a 50 N gas force, masses scaled by k
EX36 = {"crank": 0.08, "rod": 0.24}
GRAVITY = (0.0, -9.80665)


def dynamic_slider(k: float = 1.0) -> tuple[Analysis, dict]:
    mass = {"crank": (0.02 * k, 0.0), "rod": (0.06 * k, 2.88e-4 * k), "slider": (0.2 * k, 0.0)}
    an = Analysis(
        dynamic=True,
        gravity=GRAVITY,
        mass={
            "crank": MassProps(*mass["crank"], "", 0.04),
            "rod": MassProps(*mass["rod"], "", 0.12),
            "slider": MassProps(*mass["slider"]),
        },
        loads=(Load("P", "slider", (-50.0, 0.0)),),
    )
    return an, mass


def fd_driver(m: Motion, mass: dict) -> float:
    pos = reference.slider_positions(EX36["crank"], EX36["rod"], 0.04, 0.12)
    motion = reference.fd_motion(pos, m.theta, m.omega, m.alpha)
    return reference.power_balance_driver(motion, mass, {"slider": np.array([-50.0, 0.0])}, GRAVITY)


@pytest.mark.parametrize("omega", [1.0, 100.0, 1e4])
def test_speeds_against_finite_differences(omega):
    m = Motion(math.radians(45.0), omega, omega * omega / 10)
    an, mass = dynamic_slider()
    sol, _ = driven("slider_crank", EX36, m, an)
    assert sol.driver == pytest.approx(fd_driver(m, mass), rel=1e-6)


@pytest.mark.parametrize("k", [1e-6 / 0.06, 1.0, 1e3 / 0.06])
def test_masses_against_finite_differences(k):
    m = Motion(math.radians(45.0), 100.0, 0.0)
    an, mass = dynamic_slider(k)
    sol, _ = driven("slider_crank", EX36, m, an)
    assert sol.driver == pytest.approx(fd_driver(m, mass), rel=1e-6)


def test_unit_systems_and_scale_agree():
    """The same slider crank given in mm/N, m/N, in/lbf and scaled ×1e-3…×1e3: torques in N·m."""
    th = math.radians(45.0)
    ref = reference.slider_static(0.03, 0.07, th, 40.0)["T"]
    given = {
        "mm, N": (30.0, 70.0, 40.0, "mm", "N"),
        "m, N": (0.03, 0.07, 40.0, "m", "N"),
        "in, lbf": (30 / 25.4, 70 / 25.4, 40 / 4.4482216152605, "in", "lbf"),
    }
    conds = []
    for r, l_, push, lu, fu in given.values():
        p = {"crank": units.convert(r, lu, "m"), "rod": units.convert(l_, lu, "m")}
        sol, _ = driven("slider_crank", p, Motion(th, 1.0), slider_static(units.convert(push, fu, "N")))
        assert abs(sol.driver - ref) / abs(ref) < 1e-13
        conds.append(sol.condition_number)
    for s in (1e-3, 1e3):
        sol, _ = driven("slider_crank", {"crank": 0.03 * s, "rod": 0.07 * s}, Motion(th, 1.0), slider_static(40.0))
        assert abs(sol.driver / s - ref) / abs(ref) < 1e-13
        conds.append(sol.condition_number)
    assert max(conds) - min(conds) <= 1e-9 * min(conds)  # the condition number is unit-free
