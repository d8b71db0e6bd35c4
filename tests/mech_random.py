"""Random assemblable mechanisms of every kind, for the fuzz-style tests (test-only)."""

from __future__ import annotations

import math

import numpy as np

try:
    from gradekit.mechanics.errors import GeometryError
except ImportError:  # before the numeric core had its own errors
    from gradekit.errors import GeometryError
from gradekit.mechanics.mechanisms import KINDS, Motion, build
from gradekit.mechanics.model import Analysis, Load, MassProps


def random_params(kind: str, rng: np.random.Generator) -> dict:
    u = rng.uniform
    if kind == "crank":
        return {"crank": u(0.01, 1)}
    if kind == "fourbar":
        return {
            "crank": u(0.02, 0.1),
            "coupler": u(0.05, 0.3),
            "rocker": u(0.05, 0.3),
            "frame": u(0.05, 0.3),
            "frame_angle": u(-math.pi, math.pi),
            "x_O2": u(-0.1, 0.1),
            "y_O2": u(-0.1, 0.1),
        }
    if kind == "slider_crank":
        r = u(0.01, 0.1)
        return {"crank": r, "rod": r * u(1.5, 6), "offset": r * u(-0.8, 0.8), "slide_angle": u(-math.pi, math.pi)}
    if kind == "slotted_lever":
        return {"crank": u(0.02, 0.1), "frame": u(0.12, 0.3), "lever": u(0.3, 0.5), "frame_angle": u(-math.pi, math.pi)}
    if kind == "whitworth":
        r = u(0.05, 0.1)
        return {
            "crank": r,
            "frame": r * u(0.2, 0.7),
            "lever": -u(0.05, 0.12),
            "link": u(0.2, 0.4),
            "ram_offset": u(-0.05, 0.05),
        }
    if kind == "crank_shaper":
        r = u(0.03, 0.08)
        return {
            "crank": r,
            "frame": r * u(1.6, 3),
            "lever": u(0.3, 0.45),
            "link": u(0.1, 0.3),
            "ram_offset": u(0.25, 0.35),
        }
    if kind == "fourbar_quick_return":
        return {
            "crank": u(0.02, 0.04),
            "coupler": u(0.1, 0.14),
            "rocker": u(0.07, 0.1),
            "frame": u(0.1, 0.14),
            "arm": u(0.1, 0.2),
            "link": u(0.1, 0.25),
            "ram_offset": u(0.05, 0.2),
        }
    raise KeyError(kind)


def random_case(kind: str, rng: np.random.Generator, dynamic: bool = True):
    """(linkage, analysis) of a random assemblable, reasonably conditioned mechanism; None if it fails."""
    p = random_params(kind, rng)
    m = Motion(rng.uniform(0, 2 * math.pi), rng.uniform(-200, 200), rng.uniform(-5000, 5000))
    try:
        link = build(kind, p, m, int(rng.choice([-1, 1])))
    except GeometryError:
        return None
    bodies = list(link.bodies)
    mass = {
        b: MassProps(
            rng.uniform(0.01, 2), rng.uniform(1e-5, 1e-2), "", rng.uniform(-0.05, 0.1), rng.uniform(-0.02, 0.02)
        )
        for b in bodies
    }
    loads = tuple(
        Load(
            f"L{i}",
            str(rng.choice(bodies)),
            (rng.uniform(-100, 100), rng.uniform(-100, 100)),
            rng.uniform(-5, 5),
            "",
            rng.uniform(0, 0.1),
            rng.uniform(-0.02, 0.02),
        )
        for i in range(3)
    )
    return link, Analysis(dynamic, (0.0, -9.81), mass, loads, max_condition=1e6)


ALL_KINDS = tuple(KINDS)
