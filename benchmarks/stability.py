"""Solver stability at the extremes, each case checked against an independent formulation.

Independent references (none uses the solver's matrix or its jets):

* slider crank, static piston load: the closed form T = −P·r·sin(θ+β)/cos β, sin β = r·sin θ/l;
* four-bar, static load on the rocker: moment equations (coupler as a two-force member, moments
  of the rocker about O4 and of the crank about O2);
* any mechanism, static or dynamic: generalized force from finite-difference velocity ratios of
  the closed-form positions (central differences in the crank angle), T = Σ m·a_G·∂G/∂θ +
  I·α_b·∂φ/∂θ − Σ F·∂Q/∂θ − Σ τ·∂φ/∂θ.

Each table row either agrees (relative difference shown) or shows the solver's refusal message.
``python benchmarks/stability.py`` prints the tables.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from gradekit import units
from gradekit.errors import GradekitError
from gradekit.mechanics.errors import MechanicsError
from gradekit.mechanics.forces import load_point, solve
from gradekit.mechanics.mechanisms import Motion, build
from gradekit.mechanics.model import Analysis, Load, MassProps

GRAVITY = (0.0, -9.80665)


def _positions(kind: str, p: dict, theta: float, branch: int, an: Analysis):
    link = build(kind, p, Motion(theta), branch)
    g = {b: load_point(link, b, m.at, m.along, m.across).pos() for b, m in an.mass.items()}
    q = [load_point(link, ld.body, ld.at, ld.along, ld.across).pos() for ld in an.loads]
    phi = {b: float(body.angle.v) for b, body in link.bodies.items()}
    return g, q, phi


def fd_driver(kind: str, p: dict, m: Motion, an: Analysis, branch: int = 1, h: float = 1e-4) -> float:
    """Driving torque from the power balance with finite-difference velocity ratios."""
    lo, mid, hi = (_positions(kind, p, m.theta + s * h, branch, an) for s in (-1, 0, 1))

    def d1(a, b):
        return (b - a) / (2 * h)

    def ang(a, b):
        return (b - a + math.pi) % (2 * math.pi) - math.pi

    total = 0.0
    for i, ld in enumerate(an.loads):
        dq = d1(lo[1][i], hi[1][i])
        dphi = ang(lo[2][ld.body], hi[2][ld.body]) / (2 * h)
        total -= float(np.dot(ld.force, dq)) + ld.torque * dphi
    for b, mp in an.mass.items():
        dg = d1(lo[0][b], hi[0][b])
        ddg = (hi[0][b] - 2 * mid[0][b] + lo[0][b]) / h**2
        dphi = ang(lo[2][b], hi[2][b]) / (2 * h)
        ddphi = (ang(mid[2][b], hi[2][b]) - ang(lo[2][b], mid[2][b])) / h**2
        if an.gravity is not None:
            total -= mp.mass * float(np.dot(an.gravity, dg))
        if an.dynamic:
            a_g = ddg * m.omega**2 + dg * m.alpha
            alpha_b = ddphi * m.omega**2 + dphi * m.alpha
            total += mp.mass * float(np.dot(a_g, dg)) + mp.inertia * alpha_b * dphi
    return total


def solver_driver(kind: str, p: dict, m: Motion, an: Analysis, branch: int = 1) -> tuple[float, float, float]:
    """(driver, condition number, transmission angle) from the solver; raises its own errors."""
    link = build(kind, p, m, branch)
    virtual = link if m.omega else build(kind, p, Motion(m.theta, 1.0, 0.0), branch)
    sol = solve(link, an, virtual)
    return sol.driver, sol.condition_number, link.transmission


def slider_closed_form(r: float, l_: float, theta: float, push: float) -> float:
    """Crank torque balancing a force *push* on the piston towards the crank (no offset)."""
    sb = r * math.sin(theta) / l_
    beta = math.asin(sb)
    return -push * r * math.sin(theta + beta) / math.cos(beta)


def slider_static(r: float, l_: float, push: float) -> Analysis:
    return Analysis(False, None, {}, (Load("P", "slider", (-push, 0.0)),))


def fourbar_moments(p: dict, theta: float, force: tuple[float, float], along_: float, branch: int = 1) -> float:
    """Crank torque of a four-bar with *force* on the rocker *along_* from O4, by moment equations."""
    link = build("fourbar", p, Motion(theta), branch)
    o2, a, b, o4 = (link.points[k].pos() for k in ("O2", "A", "B", "O4"))
    u = (b - a) / np.hypot(*(b - a))
    q = o4 + along_ * (b - o4) / np.hypot(*(b - o4))

    def cross(x, y):
        return float(x[0] * y[1] - x[1] * y[0])

    f = -cross(q - o4, np.asarray(force)) / cross(b - o4, u)  # coupler on rocker, along u
    return cross(a - o2, f * u)  # T balances the coupler's pull -f·u on the crank at A


def _row(fn):
    try:
        return fn(), ""
    except (GradekitError, MechanicsError) as exc:
        return None, type(exc).__name__ + ": " + str(getattr(exc, "detail", exc))


def dead_centres(deltas=(1.0, 0.1, 0.01, 1e-3, 1e-4, 1e-6, 0.0)) -> list[dict]:
    """Slider crank OB = 30 mm, BC = 70 mm, P = 40 N at θ = δ and 180° − δ (Example 5.1)."""
    r, l_, push = 0.03, 0.07, 40.0
    an = slider_static(r, l_, push)
    rows = []
    for base in (0.0, 180.0):
        for d in deltas:
            th = math.radians(base + d if base == 0 else base - d)
            ref = slider_closed_form(r, l_, th, push)
            got, msg = _row(lambda th=th: solver_driver("slider_crank", {"crank": r, "rod": l_}, Motion(th), an))
            rows.append(
                {
                    "theta": f"{base:g}° {'+' if base == 0 else '−'} {d:g}°",
                    "T_ref": ref,
                    "T": got[0] if got else None,
                    "err_vs_Pr": abs(got[0] - ref) / (push * r) if got else None,
                    "cond": got[1] if got else None,
                    "refusal": msg,
                }
            )
    return rows


FOURBAR = {"crank": 0.03, "coupler": 0.10, "rocker": 0.05, "frame": 0.07}  # Example 5.3, non-Grashof


def toggle_angle(p: dict = FOURBAR) -> float:
    """Crank angle where coupler and rocker fold onto one line (|A − O4| = coupler − rocker)."""
    r, d, k = p["crank"], p["frame"], p["coupler"] - p["rocker"]
    return math.acos((r * r + d * d - k * k) / (2 * r * d))


def fourbar_toggle(deltas=(10.0, 1.0, 0.1, 0.01, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 0.0)) -> list[dict]:
    """Four-bar approaching its folded toggle: condition number and errors as μ → 0."""
    th0 = toggle_angle()
    force, along_ = (30.0, -20.0), 0.04
    an = Analysis(False, None, {}, (Load("F", "rocker", force, 0.0, "", along_),))
    rows = []
    for d in deltas:
        th = th0 + math.radians(d)
        got, msg = _row(lambda th=th: solver_driver("fourbar", FOURBAR, Motion(th), an))
        if msg:
            rows.append({"delta_deg": d, "refusal": msg})
            continue
        ref = fourbar_moments(FOURBAR, th, force, along_)
        fd = fd_driver("fourbar", FOURBAR, Motion(th), an, h=min(1e-4, math.radians(d) / 10))
        rows.append(
            {
                "delta_deg": d,
                "mu_deg": got[2],
                "T_moments": ref,
                "T": got[0] if got else None,
                "err_vs_moments": abs(got[0] - ref) / abs(ref) if got else None,
                "fd_vs_moments": abs(fd - ref) / abs(ref),
                "cond": got[1] if got else None,
                "refusal": msg,
            }
        )
    return rows


def link_ratios(ratios=(1.0, 1.5, 10.0, 100.0, 1000.0)) -> list[dict]:
    """Slider crank with rod/crank from 1:1 to 1000:1 at θ = 45°; four-bar with crank/coupler to 1:3000."""
    rows = []
    th, push = math.radians(45.0), 40.0
    for ratio in ratios:
        for r, l_ in ((0.03, 0.03 * ratio),):
            ref = slider_closed_form(r, l_, th, push)
            got, msg = _row(
                lambda r=r, l_=l_: solver_driver(
                    "slider_crank", {"crank": r, "rod": l_}, Motion(th), slider_static(r, l_, push)
                )
            )
            rows.append(
                {
                    "crank_m": r,
                    "rod_m": l_,
                    "T_ref": ref,
                    "err": abs(got[0] - ref) / abs(ref) if got else None,
                    "cond": got[1] if got else None,
                    "refusal": msg,
                }
            )
    # four-bar with a 1:1000 crank: against moment equations
    for scale in (1.0, 0.1, 0.01, 0.001):
        p = {"crank": 0.03 * scale, "coupler": 0.10, "rocker": 0.05, "frame": 0.07}
        an = Analysis(False, None, {}, (Load("F", "rocker", (30.0, -20.0), 0.0, "", 0.04),))
        ref = fourbar_moments(p, math.radians(135), (30.0, -20.0), 0.04)
        got, msg = _row(lambda p=p, an=an: solver_driver("fourbar", p, Motion(math.radians(135)), an))
        rows.append(
            {
                "crank_m": p["crank"],
                "rod_m": p["coupler"],
                "T_ref": ref,
                "err": abs(got[0] - ref) / abs(ref) if got else None,
                "cond": got[1] if got else None,
                "refusal": msg,
            }
        )
    return rows


def dynamic_slider(mass: float = 0.06, inertia: float = 2.88e-4) -> Analysis:
    """Worked Example III.6's slider crank (AB = 80, BC = 240 mm), gravity, masses scalable."""
    k = mass / 0.06
    return Analysis(
        True,
        GRAVITY,
        {
            "crank": MassProps(0.02 * k, 0.0, "", 0.04),
            "rod": MassProps(mass, inertia * k, "", 0.12),
            "slider": MassProps(0.2 * k),
        },
        (Load("P", "slider", (-50.0, 0.0)),),
    )


EX36 = {"crank": 0.08, "rod": 0.24}


def speeds(omegas=(0.0, 1.0, 100.0, 1e3, 1e4, 1e5)) -> list[dict]:
    """Dynamic slider crank at ω up to 1e5 rad/s (α = ω²/10): solver against finite differences."""
    rows = []
    for w in omegas:
        m = Motion(math.radians(45.0), w, w * w / 10)
        an = dynamic_slider()
        ref = fd_driver("slider_crank", EX36, m, an)
        got, msg = _row(lambda m=m, an=an: solver_driver("slider_crank", EX36, m, an))
        rows.append(
            {
                "omega": w,
                "T_fd": ref,
                "T": got[0] if got else None,
                "err": abs(got[0] - ref) / max(abs(ref), 1e-300) if got else None,
                "cond": got[1] if got else None,
                "refusal": msg,
            }
        )
    return rows


def masses(values=(1e-6, 1e-3, 1.0, 1e3)) -> list[dict]:
    """Masses from 1e-6 kg (the load dominates) to 1e3 kg (inertia dominates), ω = 100 rad/s."""
    rows = []
    m = Motion(math.radians(45.0), 100.0, 0.0)
    for mass in values:
        an = dynamic_slider(mass)
        ref = fd_driver("slider_crank", EX36, m, an)
        got, msg = _row(lambda an=an: solver_driver("slider_crank", EX36, m, an))
        rows.append(
            {
                "mass_kg": mass,
                "T_fd": ref,
                "T": got[0] if got else None,
                "err": abs(got[0] - ref) / abs(ref) if got else None,
                "refusal": msg,
            }
        )
    return rows


def unit_systems() -> list[dict]:
    """The same slider crank given in mm/N, m/N, in/lbf and scaled ×1e-3…×1e3: torques in N·m."""
    rows = []
    given = {
        "mm, N": (30.0, 70.0, 40.0, "mm", "N"),
        "m, N": (0.03, 0.07, 40.0, "m", "N"),
        "in, lbf": (30 / 25.4, 70 / 25.4, 40 / 4.4482216152605, "in", "lbf"),
    }
    th = math.radians(45.0)
    ref = slider_closed_form(0.03, 0.07, th, 40.0)
    for name, (r, l_, push, lu, fu) in given.items():
        r_si, l_si = units.convert(r, lu, "m"), units.convert(l_, lu, "m")
        p_si = units.convert(push, fu, "N")
        got, cond, _ = solver_driver(
            "slider_crank", {"crank": r_si, "rod": l_si}, Motion(th), slider_static(r_si, l_si, p_si)
        )
        rows.append({"system": name, "T_Nm": got, "err": abs(got - ref) / abs(ref), "cond": cond})
    for s in (1e-3, 1e3):
        got, cond, _ = solver_driver(
            "slider_crank", {"crank": 0.03 * s, "rod": 0.07 * s}, Motion(th), slider_static(0.03 * s, 0.07 * s, 40.0)
        )
        rows.append({"system": f"lengths ×{s:g}", "T_Nm": got / s, "err": abs(got / s - ref) / abs(ref), "cond": cond})
    return rows


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v).replace("|", "/")


def table(rows: list[dict]) -> str:
    """Markdown table of *rows* (dicts with the same keys)."""
    if not rows:
        return ""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(_fmt(r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


SECTIONS = {
    "Slider crank near dead centres (Example 5.1, against the closed form)": dead_centres,
    "Four-bar approaching toggle (Example 5.3 geometry, against moment equations and finite differences)": (
        fourbar_toggle
    ),
    "Link ratios (slider crank against the closed form, four-bar against moment equations)": link_ratios,
    "Speeds (dynamic slider crank of Example III.6, against finite-difference generalized forces)": speeds,
    "Masses (same, ω = 100 rad/s)": masses,
    "Unit systems and scale (against the closed form in N·m)": unit_systems,
}


def run(quick: bool = False) -> dict:
    """Every stability table; returns ``{"name", "tables": {title: rows}, "markdown"}``."""
    tables = {title: fn() for title, fn in SECTIONS.items()}
    md = "\n\n".join(f"#### {t}\n\n{table(rows)}" for t, rows in tables.items())
    return {"name": "stability", "tables": tables, "markdown": md}


if __name__ == "__main__":
    sys.stdout.write(run()["markdown"] + "\n")
