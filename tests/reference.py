"""Independent reference solutions for the tests (test-only; nothing here imports gradekit).

Each is written from the mechanics, not from the solver: closed forms of the in-line slider crank,
four-bar positions by circle intersection with its statics by moment equations (one body at a
time), and the driving torque from the power balance with finite-difference velocity ratios of
closed-form positions. The tests compare the solver with these, and these with the published
numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np


def cross(r, f) -> float:
    return float(r[0] * f[1] - r[1] * f[0])


def polar(mag: float, deg: float) -> np.ndarray:
    return np.array([mag * math.cos(math.radians(deg)), mag * math.sin(math.radians(deg))])


def angle_deg(v) -> float:
    """Direction of *v* in degrees CCW from +x, in [0, 360)."""
    return math.degrees(math.atan2(v[1], v[0])) % 360.0


# --- in-line slider crank (crank pivot at the origin, piston on +x) --------------------------------

def slider_beta(r: float, l_: float, theta: float) -> float:
    """Rod obliquity β (sin β = r·sin θ / l)."""
    return math.asin(r * math.sin(theta) / l_)


def slider_static(r: float, l_: float, theta: float, push: float) -> dict[str, float]:
    """A force *push* on the piston towards the crank: crank torque (CCW +), guide and rod forces."""
    b = slider_beta(r, l_, theta)
    return {
        "T": -push * r * math.sin(theta + b) / math.cos(b),
        "guide": push * math.tan(b),  # normal force of the frame on the piston, magnitude
        "rod": push / math.cos(b),  # rod force, magnitude
    }


def slider_kinematics(r: float, l_: float, theta: float, omega: float, rod_g: float) -> dict[str, float]:
    """Exact accelerations for constant ω: piston x'', rod angular acceleration, rod G (rod_g from A)."""
    s, c = r * math.sin(theta), r * math.cos(theta)
    d = math.sqrt(l_ * l_ - s * s)
    # x_C = c + d; derivatives in θ (ds/dθ = c, dc/dθ = -s)
    x2 = -c - (c * c - s * s) / d - (s * c) ** 2 / d**3
    # rod angle φ = atan2(-s, d): sin φ = -s / l
    phi = math.atan2(-s, d)
    dphi = -c / (l_ * math.cos(phi))
    ddphi = (s + l_ * math.sin(phi) * dphi**2) / (l_ * math.cos(phi))
    # G on the rod, rod_g from A: G = A + rod_g·(cos φ, sin φ)
    gx2 = -c + rod_g * (-math.sin(phi) * ddphi - math.cos(phi) * dphi**2)
    gy2 = -s + rod_g * (math.cos(phi) * ddphi - math.sin(phi) * dphi**2)
    w2 = omega * omega
    return {"aC": x2 * w2, "alpha_rod": ddphi * w2, "aGx": gx2 * w2, "aGy": gy2 * w2}


def slider_positions(r: float, l_: float, crank_g: float, rod_g: float) -> Callable[[float], dict]:
    """θ → {name: (point, angle)} for the crank's G, the rod's G and the piston."""

    def at(theta: float) -> dict:
        a = np.array([r * math.cos(theta), r * math.sin(theta)])
        s = r * math.sin(theta)
        c = np.array([r * math.cos(theta) + math.sqrt(l_ * l_ - s * s), 0.0])
        phi = math.atan2(c[1] - a[1], c[0] - a[0])
        return {
            "crank": (crank_g * a / r, theta),
            "rod": (a + rod_g * np.array([math.cos(phi), math.sin(phi)]), phi),
            "slider": (c, 0.0),
        }

    return at


# --- four-bar: positions by circle intersection, statics by moment equations -----------------------

def fourbar_points(crank: float, coupler: float, rocker: float, frame: float, theta: float) -> dict[str, np.ndarray]:
    """O2 at the origin, O4 on +x, crank at θ; B on the side of the frame line with the larger y."""
    o2, o4 = np.zeros(2), np.array([frame, 0.0])
    a = np.array([crank * math.cos(theta), crank * math.sin(theta)])
    d = float(np.hypot(*(o4 - a)))
    along = (coupler * coupler - rocker * rocker + d * d) / (2 * d)
    h = math.sqrt(coupler * coupler - along * along)
    u = (o4 - a) / d
    n = np.array([-u[1], u[0]])
    b = max((a + along * u + h * n, a + along * u - h * n), key=lambda p: p[1])
    return {"O2": o2, "A": a, "B": b, "O4": o4}


Load = tuple[np.ndarray, np.ndarray, float]  # (point, force, couple)


def fourbar_statics(pts: dict[str, np.ndarray], coupler: list[Load] = (), rocker: list[Load] = (),
                    crank: list[Load] = ()) -> dict:
    """Pin forces and the crank torque (CCW +) balancing *loads* on each link.

    Rocker, moments about O4; coupler, moments about A: two equations in the pin force at B. Then
    force balances give the others, and the crank's moments about O2 give the torque. Returned
    vectors: ``B`` coupler on rocker, ``A`` crank on coupler, ``O4`` frame on rocker, ``O2`` frame
    on crank.
    """
    o2, a, b, o4 = pts["O2"], pts["A"], pts["B"], pts["O4"]

    def moment(loads, about):
        return sum(cross(q - about, f) + c for q, f, c in loads)

    def total(loads):
        return sum((f for _, f, _ in loads), np.zeros(2))

    rb, ra = b - o4, b - a
    m = np.array([[-rb[1], rb[0]], [-ra[1], ra[0]]])
    f_b = np.linalg.solve(m, [-moment(rocker, o4), moment(coupler, a)])
    f_a = f_b - total(coupler)
    f_o4 = -f_b - total(rocker)
    t = cross(a - o2, f_a) - moment(crank, o2)
    f_o2 = f_a - total(crank)
    return {"T": t, "B": f_b, "A": f_a, "O4": f_o4, "O2": f_o2}


def fourbar_positions(crank: float, coupler: float, rocker: float, frame: float,
                      g: dict[str, float]) -> Callable[[float], dict]:
    """θ → {body: (G, angle)}; *g* gives each G's distance from the body's first pin (O2, A, O4)."""

    def at(theta: float) -> dict:
        p = fourbar_points(crank, coupler, rocker, frame, theta)
        out = {}
        for body, (start, end) in {"crank": ("O2", "A"), "coupler": ("A", "B"), "rocker": ("O4", "B")}.items():
            v = p[end] - p[start]
            out[body] = (p[start] + g.get(body, 0.0) * v / np.hypot(*v), math.atan2(v[1], v[0]))
        return out

    return at


# --- finite differences of closed-form positions ----------------------------------------------------

def fd_motion(positions: Callable[[float], dict], theta: float, omega: float, alpha: float = 0.0,
              h: float = 1e-4) -> dict[str, dict]:
    """Per body: G, ∂G/∂θ, a_G, angle, ∂φ/∂θ, angular acceleration (central differences)."""
    lo, mid, hi = positions(theta - h), positions(theta), positions(theta + h)

    def wrap(x):
        return (x + math.pi) % (2 * math.pi) - math.pi

    out = {}
    for k in mid:
        g0, g1, g2 = lo[k][0], mid[k][0], hi[k][0]
        dg, ddg = (g2 - g0) / (2 * h), (g2 - 2 * g1 + g0) / h**2
        dphi = wrap(hi[k][1] - lo[k][1]) / (2 * h)
        ddphi = (wrap(hi[k][1] - mid[k][1]) - wrap(mid[k][1] - lo[k][1])) / h**2
        out[k] = {
            "G": g1, "dG": dg, "aG": ddg * omega**2 + dg * alpha,
            "phi": mid[k][1], "dphi": dphi, "alpha": ddphi * omega**2 + dphi * alpha,
        }
    return out


def power_balance_driver(motion: dict[str, dict], mass: dict[str, tuple[float, float]],
                         forces: dict[str, np.ndarray], gravity=(0.0, 0.0)) -> float:
    """Driving torque from T·1 = Σ (m·a_G − m·g − F)·∂G/∂θ + I·α·∂φ/∂θ (forces applied at each G)."""
    t = 0.0
    for k, st in motion.items():
        m, inertia = mass.get(k, (0.0, 0.0))
        f = m * (st["aG"] - np.asarray(gravity)) - forces.get(k, np.zeros(2))
        t += float(np.dot(f, st["dG"])) + inertia * st["alpha"] * st["dphi"]
    return t
