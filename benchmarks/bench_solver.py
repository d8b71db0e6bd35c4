"""Solver throughput: positions per second, full pipeline (build + solve) per mechanism kind,
against the ceiling of one batched ``numpy.linalg.solve`` of the same assembled systems.

The systems are captured from the solver itself (its ``np.linalg.solve`` call), stacked and
solved in one call; the ratio ceiling/pipeline is measured within one run.
"""

from __future__ import annotations

import math
import statistics
import sys
import time

import numpy as np

from gradekit.mechanics import forces
from gradekit.mechanics.mechanisms import KINDS, Motion, build
from gradekit.mechanics.model import Analysis, Load, MassProps

try:
    from gradekit.mechanics.errors import GeometryError
except ImportError:  # before the numeric core had its own errors
    from gradekit.errors import GeometryError

ALL_KINDS = tuple(KINDS)


# --- random assemblable positions of every kind (the benchmark's own workload) ---------------------

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


def _cases(kind: str, n: int, seed: int) -> list[int]:
    """Seeds of *n* random positions of *kind* that build and solve."""
    out, s = [], seed
    while len(out) < n and s < seed + 20 * n:
        c = random_case(kind, np.random.default_rng(s))
        if c is not None:
            try:
                forces.solve(*c)
                out.append(s)
            except Exception:  # noqa: BLE001 - ill-conditioned random draws are skipped
                pass
        s += 1
    return out


def _pipeline(kind: str, seeds: list[int]) -> float:
    t = time.perf_counter()
    for s in seeds:
        link, an = random_case(kind, np.random.default_rng(s))
        forces.solve(link, an)
    return time.perf_counter() - t


def _systems(kind: str, seeds: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The (A, B) of every position, captured from the solver's own call, stacked."""
    got: list[tuple[np.ndarray, np.ndarray]] = []
    real = np.linalg.solve

    def capture(a, b):
        got.append((np.array(a), np.array(b)))
        return real(a, b)

    np.linalg.solve = capture
    try:
        for s in seeds:
            forces.solve(*random_case(kind, np.random.default_rng(s)))
    finally:
        np.linalg.solve = real
    width = max(b.shape[1] for _, b in got)
    bs = [np.pad(b, ((0, 0), (0, width - b.shape[1]))) for _, b in got]
    return np.stack([a for a, _ in got]), np.stack(bs)


def _batched(a: np.ndarray, b: np.ndarray) -> float:
    t = time.perf_counter()
    np.linalg.solve(a, b)
    return time.perf_counter() - t


def run(quick: bool = False) -> dict:
    """Positions per second per kind (median of runs), the batched ceiling and their ratio.

    Returns ``{"name", "positions", "runs", "rows": [{kind, per_second, ceiling_per_second,
    ratio, unknowns}]}``.
    """
    n, runs = (150, 3) if quick else (600, 5)
    rows = []
    for kind in ALL_KINDS:
        seeds = _cases(kind, n, 1000)
        if not seeds:
            continue
        a, b = _systems(kind, seeds)
        pipe, ceil = [], []
        for _ in range(runs):
            pipe.append(_pipeline(kind, seeds))
            ceil.append(_batched(a, b))
        tp, tc = statistics.median(pipe), statistics.median(ceil)
        rows.append(
            {
                "kind": kind,
                "positions": len(seeds),
                "unknowns": a.shape[2],
                "per_second": len(seeds) / tp,
                "ceiling_per_second": len(seeds) / tc,
                "ratio": tp / tc,
            }
        )
    return {"name": "solver", "positions": n, "runs": runs, "rows": rows}


if __name__ == "__main__":
    for r in run("--quick" in sys.argv)["rows"]:
        print(
            f"{r['kind']:22s} {r['per_second']:10.0f}/s  ceiling {r['ceiling_per_second']:12.0f}/s  ×{r['ratio']:.0f}"
        )
