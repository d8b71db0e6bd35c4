"""Solver throughput: positions per second, full pipeline (build + solve) per mechanism kind,
against the ceiling of one batched ``numpy.linalg.solve`` of the same assembled systems.

The systems are captured from the solver itself (its ``np.linalg.solve`` call), stacked and
solved in one call; the ratio ceiling/pipeline is measured within one run.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

from gradekit.mechanics import forces

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from mech_random import ALL_KINDS, random_case  # noqa: E402


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
