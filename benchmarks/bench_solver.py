"""Solver throughput, batched: `solve_many` against the bare batched ``numpy.linalg.solve`` of the
same systems (captured from the solver's own call) in the same run; per mechanism kind, batch
against one at a time; a full crank turn in one batch; and the whole `bank check` command.
"""

from __future__ import annotations

import math
import statistics
import sys
import time

import numpy as np

from gradekit.mechanics import forces
from gradekit.mechanics.mechanisms import KINDS, Motion, build, build_many
from gradekit.mechanics.model import Analysis, Load, MassProps

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


def _stack(kind: str, n: int, seed: int):
    """*n* random positions of *kind* as one batch: (linkage, analysis, branch mask used)."""
    rng = np.random.default_rng(seed)
    rows = [random_params(kind, rng) for _ in range(n)]
    params = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    motion = Motion(rng.uniform(0, 2 * math.pi, n), rng.uniform(-200, 200, n), rng.uniform(-5000, 5000, n))
    link = build_many(kind, params, motion, 1)
    bodies = list(link.bodies)
    mass = {
        b: MassProps(rng.uniform(0.01, 2, n), rng.uniform(1e-5, 1e-2, n), "", rng.uniform(-0.05, 0.1, n),
                     rng.uniform(-0.02, 0.02, n))
        for b in bodies
    }
    loads = tuple(
        Load(f"L{i}", bodies[i % len(bodies)], (rng.uniform(-100, 100, n), rng.uniform(-100, 100, n)),
             rng.uniform(-5, 5, n), "", rng.uniform(0, 0.1, n), rng.uniform(-0.02, 0.02, n))
        for i in range(3)
    )
    return params, motion, Analysis(True, (0.0, -9.81), mass, loads, max_condition=1e6)


def _capture(fn):
    """Run *fn*, recording the (A, B) of its `numpy.linalg.solve` calls."""
    got: list[tuple[np.ndarray, np.ndarray]] = []
    real = np.linalg.solve

    def capture(a, b):
        got.append((a, b))
        return real(a, b)

    np.linalg.solve = capture
    try:
        out = fn()
    finally:
        np.linalg.solve = real
    return out, got


def _best(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def bank_problem(pid: str, n: int, runs: int) -> dict:
    """`pipeline.solve_many` of one bank problem over *n* variants (parameters uniform in their
    ranges), every answer read, against the bare batched solve of the same systems."""
    from gradekit.bank.registry import load_bank
    from gradekit.solving.pipeline import published_values, solve_many

    p = load_bank()[pid]
    rng = np.random.default_rng(1)
    vals = dict(published_values(p))
    for name, par in p.parameters.items():
        if par.random and par.low is not None:
            vals[name] = rng.uniform(par.low, par.high, n)

    def everything():
        b = solve_many(p, vals, n)
        _ = [a.value for a in b.answer_list]
        return b

    everything()  # warm caches (unit factors, parsed expressions)
    batch, calls = _capture(everything)
    a, rhs = calls[-1]
    groups = len(batch.cases[0].solutions.group_names)
    t_all = _best(everything, runs)
    t_ceiling = _best(lambda: np.linalg.solve(a, rhs[:, :, :groups]), runs)
    t_same = _best(lambda: np.linalg.solve(a, rhs), runs)
    t_cond = _best(lambda: np.linalg.cond(a), max(1, runs // 2))
    return {
        "problem": pid,
        "variants": n,
        "accepted": int(batch.ok.sum()),
        "per_second": n / t_all,
        "ceiling_per_second": n / t_ceiling,
        "solve_with_inverse_per_second": n / t_same,
        "svd_cond_per_second": n / t_cond,
    }


def kinds(n: int, runs: int) -> list[dict]:
    """Per mechanism kind: random positions built and solved in one batch, and one at a time."""
    rows = []
    for kind in ALL_KINDS:
        params, motion, an = _stack(kind, n, 1000)
        link = build_many(kind, params, motion, 1)

        def batch(params=params, motion=motion, an=an, kind=kind):
            return forces.solve_many(build_many(kind, params, motion, 1), an)

        t_batch = _best(batch, runs)
        sols = batch()
        ok = np.flatnonzero(sols.ok)[:300]
        singles = [(
            {k: float(v[i]) for k, v in params.items()},
            Motion(float(motion.theta[i]), float(motion.omega[i]), float(motion.alpha[i])),
            an.take(int(i)),
        ) for i in ok]

        def one_at_a_time(singles=singles, kind=kind):
            for prm, m, a in singles:
                forces.solve(build(kind, prm, m, 1), a)

        t_one = _best(one_at_a_time, max(1, runs // 2)) / max(len(singles), 1)
        rows.append({
            "kind": kind,
            "unknowns": 2 * len(link.joints) + 1,
            "positions": n,
            "assembled": int(sols.ok.sum()),
            "batch_per_second": n / t_batch,
            "one_at_a_time_per_second": 1 / t_one if t_one else float("inf"),
        })
    return rows


def torque_cycle(runs: int) -> dict:
    """A full crank turn (360 positions) of ch5-dyn-slider-crank in one batch."""
    import dataclasses

    from gradekit.bank.registry import load_bank
    from gradekit.solving.pipeline import published_values, solve_many

    p = load_bank()["ch5-dyn-slider-crank"]
    theta = p.inputs["theta"]
    vals = {**published_values(p), theta: np.arange(360.0)}
    q = dataclasses.replace(p, cases={})
    t = _best(lambda: solve_many(q, vals, 360).cases[0].results["driver"], runs)
    return {"positions": 360, "seconds": t}


def bank_check(variants: int) -> dict:
    """The whole command `gradekit bank check --variants N` (a fresh process, start included)."""
    import subprocess

    t = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-m", "gradekit", "bank", "check", "--variants", str(variants)],
        capture_output=True, text=True,
    )
    return {"variants": variants, "seconds": time.perf_counter() - t, "passed": out.returncode == 0}


def markdown(res: dict) -> str:
    b = res["bank_problem"]
    lines = [
        f"**`solve_many` on {b['problem']}**, {b['variants']:,} variants (parameters uniform in their ranges), "
        f"median of {res['runs']} runs, in one process: build (positions on jets) + assembly + one batched "
        "solve + the condition-number refusal test + virtual-work check + every answer read.",
        "",
        "| what | variants/s |",
        "|---|---|",
        f"| `solve_many`, everything above | {b['per_second']:,.0f} |",
        f"| bare batched `numpy.linalg.solve` of the same systems (ceiling) | {b['ceiling_per_second']:,.0f} |",
        "| the same solve with the 9 extra columns that give the inverse | "
        f"{b['solve_with_inverse_per_second']:,.0f} |",
        f"| an SVD condition number of the same systems (what the bounds avoid) | {b['svd_cond_per_second']:,.0f} |",
        "",
        f"Per mechanism kind, {res['kinds'][0]['positions']:,} random positions (random geometry, speeds, masses and "
        "three loads each; those that cannot assemble are refused by mask), core only (`build_many` + "
        "`forces.solve_many`), against the same positions one at a time (`build` + `forces.solve`):",
        "",
        "| kind | unknowns | assembled | batch positions/s | one at a time /s | speed-up |",
        "|---|---|---|---|---|---|",
    ]
    for r in res["kinds"]:
        lines.append(
            f"| {r['kind']} | {r['unknowns']} | {r['assembled']:,} | {r['batch_per_second']:,.0f} "
            f"| {r['one_at_a_time_per_second']:,.0f} | ×{r['batch_per_second'] / r['one_at_a_time_per_second']:,.0f} |"
        )
    c, k = res["torque_cycle"], res["bank_check"]
    lines += [
        "",
        f"A full crank turn of ch5-dyn-slider-crank ({c['positions']} positions) in one batch: "
        f"{c['seconds'] * 1000:.1f} ms.",
        "",
        f"`gradekit bank check --variants {k['variants']}` over the whole bank, the whole command in a fresh "
        f"process: {k['seconds']:.1f} s ({'passed' if k['passed'] else 'FAILED'}).",
    ]
    return "\n".join(lines)


def run(quick: bool = False) -> dict:
    """Batched solver throughput against its ceiling, per kind, a torque cycle and the bank check."""
    n, per_kind, runs = (20_000, 2_000, 3) if quick else (100_000, 20_000, 5)
    res = {
        "name": "solver",
        "runs": runs,
        "bank_problem": bank_problem("ch5-ex5-3", n, runs),
        "kinds": kinds(per_kind, runs),
        "torque_cycle": torque_cycle(runs),
        "bank_check": bank_check(200 if quick else 1000),
    }
    res["markdown"] = markdown(res)
    return res


if __name__ == "__main__":
    print(run("--quick" in sys.argv)["markdown"])
