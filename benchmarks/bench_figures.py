"""Per-figure time of `gradekit.figures`: build + SVG, median over every bank problem's figures.

Run: ``python benchmarks/bench_figures.py [--quick]``; prints
``figures: median X ms per figure (N figures)``. Each figure of each problem's published variant
(the scene, its true-scale drawing and every key figure) is timed in-process, several runs, after
one warm-up run (imports, fonts and unit parsing are paid once per process, not per figure).
"""

from __future__ import annotations

import statistics
import sys
import time


def _jobs():
    from gradekit import figures
    from gradekit.bank.registry import load_bank
    from gradekit.figures.key import key_figure_specs
    from gradekit.solving.sampling import variant

    jobs = []
    for pid, problem in load_bank().items():
        result = variant(problem).result
        jobs.append((f"{pid}/scene", lambda r=result: figures.scene(r)))
        if problem.figure.true_scale:
            jobs.append((f"{pid}/scene-true-scale", lambda r=result: figures.scene(r, true_scale=True)))
        for slug, _caption, make in key_figure_specs(result):
            jobs.append((f"{pid}/{slug}", make))
    return jobs


def run(quick: bool = False) -> dict:
    """Time every figure; return the median and the per-figure medians in milliseconds."""
    from gradekit.figures import to_svg

    jobs = _jobs()
    runs = 2 if quick else 5
    for _name, make in jobs:  # warm-up
        to_svg(make())
    times: dict[str, list[float]] = {name: [] for name, _ in jobs}
    for _ in range(runs):
        for name, make in jobs:
            t0 = time.perf_counter()
            to_svg(make())
            times[name].append((time.perf_counter() - t0) * 1000.0)
    per = {name: statistics.median(v) for name, v in times.items()}
    return {"median_ms": statistics.median(per.values()), "figures": len(per), "runs": runs,
            "max_ms": max(per.values()), "per_figure_ms": per}


def main(argv: list[str]) -> None:
    res = run("--quick" in argv)
    if "-v" in argv:
        for name, ms in sorted(res["per_figure_ms"].items(), key=lambda kv: -kv[1]):
            print(f"  {ms:7.1f} ms  {name}")
    print(f"figures: median {res['median_ms']:.1f} ms per figure ({res['figures']} figures; "
          f"slowest {res['max_ms']:.1f} ms; median of {res['runs']} runs each)")


if __name__ == "__main__":
    main(sys.argv[1:])
