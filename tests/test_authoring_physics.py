"""The quantities and loads an author can ask for (issue 14), each against an independent formulation:
positions against a closed-form closure, velocities and accelerations against finite differences of
positions, the shaking force and moment against the momentum of the links, derived answers against
their definition, and every motion-dependent load against an energy balance (driver power = rate of
kinetic energy + the damper's dissipation + the spring's stored power)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gradekit.bank.schema import load_problem
from gradekit.solving.pipeline import published_values
from gradekit.solving.pipeline import solve_many as solve_batch

BASE = """\
id: t-fourbar
title: test four-bar
source: {document: test, ref: test}
method: analytical
analysis: ANALYSIS
units: mm-N-s
mechanism:
  type: fourbar
  labels: {ground: "1", crank: "2", coupler: "3", rocker: "4"}
  geometry: {crank: r2, coupler: r3, rocker: r4, frame: r1, frame_angle: 10, x_O2: 20, y_O2: -15}
  input: {theta: th, omega: w2}
  points:
    P: {on: coupler, from: A, along: 50, perp: 30}
    G2: {on: crank, from: O2, along: 20, perp: 5}
    G4: {on: rocker, from: O4, along: 70, perp: -8}
    E: {on: ground, from: O2, along: 60, perp: 110}
parameters:
  r1: {value: 140, unit: mm}
  r2: {value: 50, unit: mm}
  r3: {value: 150, unit: mm}
  r4: {value: 120, unit: mm}
  th: {value: 60, unit: deg}
  w2: {value: 10, unit: rad/s}
  c: {value: 0.8, unit: N*s/mm}
MASS
LOADS
statement: "x"
answers:
"""
MASS = """\
mass:
  crank: {mass: 1.0, inertia: 2000, at: G2}
  coupler: {mass: 2.0, inertia: 5000, at: P}
  rocker: {mass: 1.5, inertia: 4000, at: G4}
"""
ANSWERS = [
    ("T", "driver", "N*m"),
    ("Sx", "shaking.x", "N"),
    ("Sy", "shaking.y", "N"),
    ("Ms", "shaking_moment", "N*m"),
    ("mT", "-driver", "N*m"),
    ("Fa", "along(F[2,3], 3)", "N"),
    ("Fp", "perp(F[2,3], 3)", "N"),
    ("F23x", "F[2,3].x", "N"),
    ("F23y", "F[2,3].y", "N"),
    ("A4", "r[B].angle", "deg"),
]
POINTS = ("A", "B", "P", "G2", "G4", "O4")
for _p in POINTS:
    ANSWERS += [(f"r{_p}x", f"r[{_p}].x", "m"), (f"r{_p}y", f"r[{_p}].y", "m")]
for _p in ("P", "B"):
    ANSWERS += [(f"v{_p}{c}", f"v[{_p}].{c}", "m/s") for c in "xy"] + [(f"a{_p}{c}", f"a[{_p}].{c}", "m/s**2")
                                                                    for c in "xy"]
for _k in "234":
    ANSWERS += [(f"th{_k}", f"theta[{_k}]", "deg"), (f"w{_k}", f"omega[{_k}]", "rad/s")]

M = {"2": 1.0, "3": 2.0, "4": 1.5}  # kg
I = {"2": 2000e-6, "3": 5000e-6, "4": 4000e-6}  # kg·m²
G = {"2": "G2", "3": "P", "4": "G4"}
W2 = 10.0


def problem(tmp_path: Path, analysis="dynamic", loads="", mass=MASS, extra=""):
    text = BASE.replace("ANALYSIS", analysis).replace("MASS", mass).replace("LOADS", loads) + "".join(
        f'  - {{key: {k}, of: "{of}", unit: "{u}", description: t}}\n' for k, of, u in ANSWERS
    ) + extra
    f = tmp_path / "t.yaml"
    f.write_text(text, encoding="utf-8")
    return load_problem(f)


def around(p, theta_deg: float, h_deg: float):
    """Solve at θ − 2h … θ + 2h in one batch; return ``answers`` (key → array of 5) and h in rad."""
    vals = published_values(p)
    vals["th"] = theta_deg + h_deg * np.arange(-2, 3)
    b = solve_batch(p, vals)
    assert b.ok.all()
    assert (b.virtual_work_residual < 1e-9).all()
    return b.answers, math.radians(h_deg)


def d1(y, h):
    """First derivative at the middle of five samples (fourth-order central difference)."""
    return (-y[4] + 8 * y[3] - 8 * y[1] + y[0]) / (12 * h)


def d2(y, h):
    """Second derivative at the middle of five samples (fourth-order central difference)."""
    return (-y[4] + 16 * y[3] - 30 * y[2] + 16 * y[1] - y[0]) / (12 * h**2)


def test_positions_are_the_closure_of_the_loop_from_the_origin(tmp_path):
    p = problem(tmp_path, "static", mass="")
    ans, _ = around(p, 60.0, 1.0)
    o2 = np.array([0.020, -0.015])
    th = math.radians(60.0)
    a = o2 + 0.050 * np.array([math.cos(th), math.sin(th)])
    o4 = o2 + 0.140 * np.array([math.cos(math.radians(10)), math.sin(math.radians(10))])
    # B: the intersection of circles (A, 150) and (O4, 120) on the left of A→O4, by the law of cosines
    d = np.linalg.norm(o4 - a)
    gamma = math.acos((d**2 + 0.150**2 - 0.120**2) / (2 * d * 0.150))
    base = math.atan2(*(o4 - a)[::-1])
    b = a + 0.150 * np.array([math.cos(base + gamma), math.sin(base + gamma)])
    for name, pt in (("A", a), ("B", b), ("O4", o4)):
        assert ans[f"r{name}x"][2] == pytest.approx(pt[0] - o2[0], abs=1e-12)
        assert ans[f"r{name}y"][2] == pytest.approx(pt[1] - o2[1], abs=1e-12)
    # P: 50 along A→B and 30 to its left
    u = (b - a) / 0.150
    n = np.array([-u[1], u[0]])
    pp = a + 0.050 * u + 0.030 * n
    assert (ans["rPx"][2], ans["rPy"][2]) == pytest.approx(tuple(pp - o2), abs=1e-12)
    assert ans["A4"][2] == pytest.approx(math.degrees(math.atan2(b[1] - o2[1], b[0] - o2[0])) % 360, abs=1e-9)
    assert ans["th3"][2] == pytest.approx(math.degrees(math.atan2(u[1], u[0])) % 360, abs=1e-9)


def test_an_origin_and_an_angle_range_chosen_by_the_author(tmp_path):
    p = problem(tmp_path, "static", mass="", extra="origin: O4\nangle_range: [-180, 180]\n")
    ans, _ = around(p, 200.0, 1.0)
    assert ans["rO4x"][2] == 0 and ans["rO4y"][2] == 0
    assert -180 <= ans["th2"][2] < 180 and ans["th2"][2] == pytest.approx(200.0 - 360.0)


@pytest.mark.parametrize("theta", [35.0, 160.0, 290.0])
def test_velocity_and_acceleration_of_any_point_are_the_derivatives_of_its_position(tmp_path, theta):
    p = problem(tmp_path, "static", mass="", loads=_DAMPER)  # a motion-dependent load: real speed, α2 = 0
    ans, h = around(p, theta, 0.01)
    for pt in ("P", "B"):
        for c in "xy":
            r = ans[f"r{pt}{c}"]
            assert ans[f"v{pt}{c}"][2] == pytest.approx(d1(r, h) * W2, rel=1e-6, abs=1e-9)
            assert ans[f"a{pt}{c}"][2] == pytest.approx(d2(r, h) * W2**2, rel=1e-4, abs=1e-6)
    for k in "34":
        assert ans[f"w{k}"][2] == pytest.approx(d1(np.radians(np.unwrap(ans[f"th{k}"], period=360)), h) * W2,
                                                rel=1e-6)


def _kinematics(ans, h):
    """Velocity, acceleration of each centre of mass and ω, α of each link, by finite differences."""
    out = {}
    for k, g in G.items():
        r = np.array([ans[f"r{g}x"], ans[f"r{g}y"]])
        th = np.radians(np.unwrap(ans[f"th{k}"], period=360))
        out[k] = (r[:, 2], d1(r.T, h) * W2, d2(r.T, h) * W2**2, d1(th, h) * W2, d2(th, h) * W2**2)
    return out


@pytest.mark.parametrize("theta", [35.0, 160.0, 290.0])
def test_shaking_force_and_moment_are_the_rate_of_change_of_momentum(tmp_path, theta):
    """No loads, no gravity: what the frame feels is −Σ m·a_G, and its moment about the origin
    −Σ (r_G × m·a_G + I·α) (the driver's reaction included), from positions alone."""
    p = problem(tmp_path, "dynamic")
    ans, h = around(p, theta, 0.01)
    kin = _kinematics(ans, h)
    force = -sum(M[k] * kin[k][2] for k in G)
    moment = -sum(M[k] * (kin[k][0][0] * kin[k][2][1] - kin[k][0][1] * kin[k][2][0]) + I[k] * kin[k][4] for k in G)
    assert (ans["Sx"][2], ans["Sy"][2]) == pytest.approx(tuple(force), rel=1e-4, abs=1e-6)
    assert ans["Ms"][2] == pytest.approx(moment, rel=1e-4, abs=1e-7)


def test_derived_answers_are_their_definitions(tmp_path):
    p = problem(tmp_path, "dynamic")
    ans, _ = around(p, 75.0, 1.0)
    assert ans["mT"][2] == -ans["T"][2]
    th3 = math.radians(ans["th3"][2])
    f = np.array([ans["F23x"][2], ans["F23y"][2]])
    assert ans["Fa"][2] == pytest.approx(f @ [math.cos(th3), math.sin(th3)], rel=1e-12)
    assert ans["Fp"][2] == pytest.approx(f @ [-math.sin(th3), math.cos(th3)], rel=1e-12)
    assert math.hypot(ans["Fa"][2], ans["Fp"][2]) == pytest.approx(float(np.hypot(*f)), rel=1e-12)


_DAMPER = """\
loads:
  - {name: D, type: damper, between: [E, P], c: c}
"""
_SPRING = """\
loads:
  - {name: S, type: spring, between: [E, P], k: 2.5, free_length: 60}
"""
_ROTARY = """\
loads:
  - {name: R, type: rotary_damper, link: 3, c: 900}
"""
_RELATIVE = """\
loads:
  - {name: R, type: rotary_damper, link: 4, relative_to: coupler, c: 900}
"""
_RESIST = """\
loads:
  - {name: Q, type: resistance, at: P, magnitude: 40}
"""


def _power_of_loads(kind: str, ans, h) -> float:
    """The power the loads absorb (dissipated by dampers and resistances, stored by springs)."""
    rp = np.array([ans["rPx"], ans["rPy"]]).T
    e = np.array([0.060, 0.110])  # E: on the ground, 60 along +x and 110 across from O2 (the origin)
    length = np.hypot(*(rp - e).T)
    rate = d1(length, h) * W2
    if kind == "damper":
        return 0.8e3 * rate**2  # c = 0.8 N·s/mm
    if kind == "spring":
        return 2.5e3 * (length[2] - 0.060) * rate
    w = {k: d1(np.radians(np.unwrap(ans[f"th{k}"], period=360)), h) * W2 for k in "34"}
    if kind == "rotary":
        return 900e-3 * w["3"] ** 2  # c = 900 N·mm·s
    if kind == "relative":
        return 900e-3 * (w["4"] - w["3"]) ** 2
    speed = np.hypot(d1(rp[:, 0], h), d1(rp[:, 1], h)) * W2
    return 40.0 * speed


@pytest.mark.parametrize("analysis", ["static", "dynamic"])
@pytest.mark.parametrize(
    ("kind", "loads"),
    [("damper", _DAMPER), ("spring", _SPRING), ("rotary", _ROTARY), ("relative", _RELATIVE), ("resist", _RESIST)],
)
@pytest.mark.parametrize("theta", [35.0, 160.0, 290.0])
def test_driver_power_balances_kinetic_energy_and_the_loads_power(tmp_path, analysis, kind, loads, theta):
    """T·ω2 = d(KE)/dt + (power into the loads): every term from positions by finite differences."""
    p = problem(tmp_path, analysis, loads=loads)
    ans, h = around(p, theta, 0.01)
    kin = _kinematics(ans, h)
    dke = sum(M[k] * kin[k][1] @ kin[k][2] + I[k] * kin[k][3] * kin[k][4] for k in G) if analysis == "dynamic" else 0
    absorbed = _power_of_loads(kind, ans, h)
    assert absorbed != pytest.approx(0, abs=1e-3)  # the load does work at this position
    assert ans["T"][2] * W2 == pytest.approx(dke + absorbed, rel=1e-5)


def test_a_resistance_at_a_point_at_rest_is_refused_with_its_reason(tmp_path):
    p = problem(tmp_path, "static", mass="", loads="loads:\n  - {name: Q, type: resistance, at: O4, body: 4, "
                "magnitude: 40}\n")
    vals = published_values(p)
    b = solve_batch(p, vals)
    assert not b.ok[0] and "at rest" in b.reason(0)
