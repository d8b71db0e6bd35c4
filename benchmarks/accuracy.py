"""Accuracy studies: tolerances from simulated students, Monte-Carlo stability, crank-angle
resolution of a torque curve, figure resolution against time.

``python benchmarks/accuracy.py [--quick]`` prints the markdown; `run` returns it with the data
and writes PNG plots into ``benchmarks/plots/``.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gradekit.bank.registry import load_bank  # noqa: E402
from gradekit.errors import GradekitError  # noqa: E402
from gradekit.figures.sheet import printed_scale  # noqa: E402
from gradekit.solving.keys import Tolerance  # noqa: E402
from gradekit.solving.pipeline import published_values, solve_problem  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import tolerance_study as ts  # noqa: E402

PLOTS = Path(__file__).resolve().parent / "plots"


DRAWING_MODEL = (
    "Honest models: every given value and written intermediate (link angles, rates, joint coordinates) to 3 "
    "and to 4 significant figures, ±0.5 in the last digit kept; for graphical problems also the construction "
    "on the printed sheet: points taken off the figure at its printed scale to ±0.5 mm in x and y (so lines "
    "of action through them are off as the sheet makes them), directions laid off to ±0.5°, velocity, "
    "acceleration and force polygons (each superposition part its own) at the 1-2-5 scale that draws the "
    "largest vector 60–150 mm long, each vector laid off and read to ±0.5 mm; a torque as the moment of the "
    "driven link's pin force about its pivot (the force's component across the link read off the polygon, "
    "times the pin's radius); answers written to 3 significant figures. Scored with the grader's own "
    "`Tolerance.accepts_many` (floor resolved per variant, angles wrapped at 360°)."
)


def _pct(x: float) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.2f} %"


def _band(t: Tolerance, unit: str = "") -> str:
    if t.period:
        return f"±{t.abs:g}°"
    text = f"±{100 * t.rel:g} %" + (f", floor {100 * t.floor:g} % of scale" if t.floor else "")
    return text + (f", at least ±{t.abs:g} {unit}".rstrip() if t.abs else "")


def _ub(x: float) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.3f} %"


MODEL_NAMES = {"sf3": "3 s.f.", "sf4": "4 s.f.", "sf5": "5 s.f.", "drawing": "drawing"}


def choice_band(st: ts.Study, key: str) -> str:
    s = ts.choose(st.answers[key], st.method)
    return f"{_band(s.tolerance)}, bound {_ub(s.worst_bound())}"


def tolerance_tables(studies: list[ts.Study], bank: dict) -> tuple[str, dict]:
    """Markdown: per-kind defaults, per problem the honest false-reject upper bound at the bands the
    grader applies (the loaded bank's), and the mistakes those bands cannot catch."""
    defaults = ts.kind_defaults(studies)
    out = [
        "#### Per-kind defaults (`_kind_defaults` of problem_bank/_tolerances.yaml, read by "
        "gradekit/solving/tolerances.py)",
        "",
        "For answers without a row: the narrowest band whose 95 % upper bound of the honest false-reject rate, "
        "pooled over the kind's answers in the bank (those no band admits left out), is below 0.1 % for every "
        "honest model.",
        "",
        "| method | kind | band | pooled upper bound (worst model) | mean detection of each answer's worst mistake |",
        "|---|---|---|---|---|",
    ]
    for (method, kind), (tol, ub, det) in sorted(defaults.items()):
        out.append(f"| {method} | {kind} | {_band(tol)} | {_ub(ub)} | {_pct(det)} |")
    out += [
        "",
        "#### Per problem, at the bands the grader applies",
        "",
        "Each answer's band as the bank loads it (the band its file states in `constraints.bands`, copied with "
        "its measurement into `problem_bank/_tolerances.yaml`), scored by `Tolerance.accepts_many`. *Worst upper "
        "bound*: the largest one-sided 95 % Clopper–Pearson upper bound of the honest false-reject rate over the "
        "problem's answers, per model (rejected / honest answers of the worst answer).",
        "",
        "| problem | method | variants × students | answers | worst upper bound: the sheet's figures | one more "
        "| drawing | all < 0.1 % | answers with an undetectable mistake |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    per_problem: dict[str, dict] = {}
    undetectable: list[str] = []
    above: list[str] = []
    all_ok = True
    for st in studies:
        specs = {a.key: a for a in bank[st.problem.id].answers}
        worst: dict[str, tuple[float, str, int, int]] = {}
        short = 0
        rows = {}
        for a in st.answers.values():
            if specs[a.key].hand_check:  # not graded automatically (RESULTS, Discrimination)
                continue
            tol = specs[a.key].tolerance
            sc = ts.evaluate(a, tol, st.models)
            rows[a.key] = {
                "band": _band(tol, a.unit),
                "upper_bound": {m: sc.bound(m) for m in sc.samples},
                "rejected": sc.rejected,
                "samples": sc.samples,
                "detection": sc.detection,
            }
            for m in sc.samples:
                if m not in worst or sc.bound(m) > worst[m][0]:
                    worst[m] = (sc.bound(m), a.key, sc.rejected[m], sc.samples[m])
            missed = {n: r for n, r in sc.detection.items() if r < ts.DETECT_MIN}
            if missed:
                short += 1
                undetectable.append(
                    f"| {st.problem.id} | {a.key} | {_band(tol, a.unit)} | "
                    + "; ".join(f"{n} ({_pct(r)} caught)" for n, r in sorted(missed.items(), key=lambda kv: kv[1]))
                    + " |"
                )
        ok = all(w[0] < ts.FALSE_REJECT_MAX for w in worst.values())
        for key, r in rows.items():
            over = {m: ub for m, ub in r["upper_bound"].items() if ub >= ts.FALSE_REJECT_MAX}
            if over:
                above.append(
                    f"| {st.problem.id} | {key} | {r['band']} | "
                    + "; ".join(
                        f"{MODEL_NAMES[m]}: {r['rejected'][m]}/{r['samples'][m]} rejected, bound {_ub(ub)}"
                        for m, ub in over.items()
                    )
                    + f" | {choice_band(st, key)} |"
                )
        all_ok &= ok

        def cell(m: str, worst=worst) -> str:
            if m not in worst:
                return "—"
            ub, key, k, n = worst[m]
            return f"{_ub(ub)} ({key}: {k}/{n})"

        out.append(
            f"| {st.problem.id} | {st.method} | {st.variants} × {st.per_variant} | {len(st.answers)} | "
            f"{cell(st.models[0])} | {cell(st.models[1])} | {cell('drawing')} | {'yes' if ok else '**no**'} | {short} |"
        )
        per_problem[st.problem.id] = rows
    out.insert(0, f"**Every answer of every problem below 0.1 % (95 % upper bound): {'yes' if all_ok else 'NO'}.**\n")
    out += [
        "",
        "#### Answers whose honest false-reject bound is not below 0.1 %",
        "",
        "| problem | answer | band applied | honest rejections | study's band (where none admits honest work: "
        "the one with fewest rejections) |",
        "|---|---|---|---|---|",
        *(above or ["| — | — | — | — | — |"]),
    ]
    out += [
        "",
        "#### Mistakes the honest band cannot catch (caught < 99 % of the time)",
        "",
        "Where no band admits honest work and catches a catalogued mistake, honest students win: the band "
        "admits them and the mistake below is not reliably detectable on that answer.",
        "",
        "| problem | answer | band | mistake (share of variants where it falls outside the band) |",
        "|---|---|---|---|",
        *undetectable,
    ]
    data = {
        "all_below": all_ok,
        "defaults": {
            f"{m}/{k}": {"band": _band(t), "upper_bound": ub, "detection": det}
            for (m, k), (t, ub, det) in defaults.items()
        },
        "answers": per_problem,
    }
    return "\n".join(out), data


def plot_honest(studies: list[ts.Study], path: Path) -> None:
    """99.9 % quantile of honest errors per answer, by kind and model."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    kinds = sorted({a.kind for st in studies for a in st.answers.values()} - {"angle"})
    for ax, angle in zip(axes, (False, True), strict=True):
        for j, m in enumerate(ts.MODELS):
            xs, ys = [], []
            for st in studies:
                for a in st.answers.values():
                    if (a.kind == "angle") != angle or m not in a.honest:
                        continue
                    e = ts.honest_errors(a, m)
                    if e.size:
                        xs.append((0 if angle else kinds.index(a.kind)) + 0.2 * (j - 1))
                        ys.append(np.quantile(e, 0.999) * (1 if angle else 100))
            ax.scatter(xs, ys, s=12, label=MODEL_NAMES[m], alpha=0.7)
        ax.set_yscale("log")
        if angle:
            ax.set_xticks([0], ["angle"])
            ax.set_ylabel("99.9 % honest error (degrees)")
        else:
            ax.set_xticks(range(len(kinds)), kinds, rotation=20)
            ax.set_ylabel("99.9 % honest relative error (%)")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle("Honest-student errors per answer (3 s.f., 4 s.f., drawing)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_tradeoff(st: ts.Study, key: str, path: Path) -> None:
    """False-reject upper bound and detection rates against the relative band for one answer."""
    a = st.answers[key]
    rels = np.array(ts.REL_GRID)
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for m in st.models:
        ub = [ts.evaluate(a, Tolerance("relative", r, 0.0), (m,)).bound(m) for r in rels]
        ax.plot(100 * rels, np.maximum(ub, 1e-5), "o-", label=f"false reject, 95 % bound ({MODEL_NAMES[m]})")
    for name in a.mistakes:
        det = [ts.evaluate(a, Tolerance("relative", r, 0.0), ()).detection.get(name, np.nan) for r in rels]
        ax.plot(100 * rels, det, "--", label=f"detect: {name}")
    ax.axhline(ts.FALSE_REJECT_MAX, color="k", lw=0.6)
    ax.axhline(ts.DETECT_MIN, color="k", lw=0.6)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("relative band (%)")
    ax.set_ylabel("rate")
    ax.set_title(f"{st.problem.id} {key}: honest rejects vs mistakes caught")
    ax.legend(fontsize=6, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def mc_stability(st: ts.Study, key: str, path: Path, reps: int = 200) -> tuple[str, list[dict]]:
    """Derived tolerance (99.9 % quantile of sf3 relative error) against the sample count: draws of
    n without replacement from a pool of *st*'s honest answers (n up to a third of the pool)."""
    pool = ts.honest_errors(st.answers[key], "sf3")
    rng = np.random.default_rng(7)
    rows = []
    for n in (30, 100, 300, 1000, 3000, 10000):
        if 3 * n > pool.size:
            break
        qs = [np.quantile(rng.choice(pool, n, replace=False), 0.999) for _ in range(reps)]
        rows.append(
            {
                "samples": n,
                "median": float(np.median(qs)),
                "p5": float(np.quantile(qs, 0.05)),
                "p95": float(np.quantile(qs, 0.95)),
            }
        )
    fig, ax = plt.subplots(figsize=(6, 3.8))
    ns = [r["samples"] for r in rows]
    ax.fill_between(ns, [100 * r["p5"] for r in rows], [100 * r["p95"] for r in rows], alpha=0.3, label="5–95 %")
    ax.plot(ns, [100 * r["median"] for r in rows], "o-", label="median")
    ax.set_xscale("log")
    ax.set_xlabel("Monte-Carlo honest samples")
    ax.set_ylabel("derived tolerance: 99.9 % error (%)")
    ax.set_title(f"{st.problem.id} {key} (sf3), subsamples of a pool of {pool.size}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    md = [
        f"Pool: {pool.size} honest 3-s.f. answers of {st.problem.id} `{key}`, "
        f"{reps} draws without replacement per size.",
        "",
    ]
    md += ["| samples | derived tolerance (median) | 5 % | 95 % | spread |", "|---|---|---|---|---|"]
    md += [
        f"| {r['samples']} | {_pct(r['median'])} | {_pct(r['p5'])} | {_pct(r['p95'])} | "
        f"{_pct((r['p95'] - r['p5']) / r['median'])} |"
        for r in rows
    ]
    return "\n".join(md), rows


def crank_resolution(pid: str, path: Path, quick: bool = False) -> tuple[str, list[dict]]:
    """Full-cycle input torque at crank-angle steps; error of its (signed) peak against a refined peak."""
    problem = load_bank()[pid]
    name = problem.inputs["theta"]
    base = published_values(problem)

    def torque(deg: float) -> float:
        try:
            r = solve_problem(problem, {**base, name: deg})
        except GradekitError:
            return math.nan
        return next(a.value for a in r.answers if a.of == "driver")

    fine = np.arange(0.0, 360.0, 0.25 if quick else 0.05)
    tf = np.array([torque(d) for d in fine])
    i = int(np.nanargmax(tf))
    lo, hi = fine[i] - (fine[1] - fine[0]), fine[i] + (fine[1] - fine[0])  # golden-section refinement of the peak
    g = (math.sqrt(5) - 1) / 2
    for _ in range(40):
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if torque(a) > torque(b):
            hi = b
        else:
            lo = a
    peak_angle = (lo + hi) / 2
    peak = torque(peak_angle)
    rows = []
    for step in (30.0, 15.0, 10.0, 5.0, 2.0, 1.0, 0.5) + (() if quick else (0.1,)):
        grid = np.arange(0.0, 360.0, step)
        t0 = time.perf_counter()
        vals = np.array([torque(d) for d in grid])
        dt = time.perf_counter() - t0
        j = int(np.nanargmax(vals))
        rows.append(
            {
                "step_deg": step,
                "positions": grid.size,
                "peak_error": (peak - vals[j]) / peak,
                "angle_error_deg": abs(grid[j] - peak_angle),
                "seconds": dt,
            }
        )
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    ax1.plot(fine, tf, lw=1)
    ax1.axvline(peak_angle, color="r", lw=0.6)
    ax1.set_xlabel("crank angle (deg)")
    ax1.set_ylabel("T (problem unit)")
    ax1.set_title(f"{pid}: input torque over a cycle")
    ax2.loglog([r["step_deg"] for r in rows], [max(r["peak_error"], 1e-12) for r in rows], "o-")
    ax2.set_xlabel("crank-angle step (deg)")
    ax2.set_ylabel("relative error of the peak")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    md = [f"Peak T = {peak:.6g} at φ = {peak_angle:.4f}° ({fine[1] - fine[0]:g}° scan refined by golden section).", ""]
    md += ["| step | positions | peak error | angle error | time |", "|---|---|---|---|---|"]
    md += [
        f"| {r['step_deg']:g}° | {r['positions']} | {r['peak_error']:.2e} | {r['angle_error_deg']:.3f}° | "
        f"{1e3 * r['seconds']:.0f} ms |"
        for r in rows
    ]
    return "\n".join(md), rows


def figure_timing(pid: str, runs: int) -> tuple[str, list[dict]]:
    """Scene figure: SVG and PNG at several dpi, median seconds and bytes."""
    try:
        from gradekit.figures import scene, to_png, to_svg
    except ImportError as exc:
        return f"(skipped: gradekit.figures not available: {exc})", []
    from gradekit.solving.sampling import variant

    res = variant(load_bank()[pid]).result
    rows = []
    for fmt, dpi in (("svg", None), ("png", 72), ("png", 110), ("png", 200), ("png", 300)):
        times, size = [], 0
        for _ in range(runs):
            t = time.perf_counter()
            fig = scene(res)
            size = len(to_svg(fig) if fmt == "svg" else to_png(fig, dpi))
            times.append(time.perf_counter() - t)
        rows.append({"format": fmt, "dpi": dpi, "seconds": statistics.median(times), "bytes": size})
    md = [f"Assignment scene of {pid}, median of {runs} (scene + serialise).", ""]
    md += ["| format | dpi | time | size |", "|---|---|---|---|"]
    md += [
        f"| {r['format']} | {r['dpi'] or '—'} | {1e3 * r['seconds']:.0f} ms | {r['bytes'] / 1024:.0f} KiB |"
        for r in rows
    ]
    return "\n".join(md), rows


def run(quick: bool = False) -> dict:
    """Every accuracy study; ``{"name", "markdown", "data", "plots"}``."""
    PLOTS.mkdir(exist_ok=True)
    nv, k = (50, 10) if quick else (500, 10)
    bank = load_bank()
    studies, skipped = [], []
    t0 = time.perf_counter()
    for pid, problem in sorted(bank.items()):
        try:
            studies.append(ts.simulate(problem, nv, k, printed_scale=printed_scale))
        except GradekitError as exc:
            skipped.append(f"{pid}: {exc}")
    t_study = time.perf_counter() - t0
    md, data = tolerance_tables(studies, bank)
    plots = {}
    plots["honest"] = PLOTS / "honest_errors.png"
    plot_honest(studies, plots["honest"])
    by_id = {st.problem.id: st for st in studies}
    md_parts = [
        f"Tolerance study (`benchmarks/tolerance_study.py`): {len(studies)} problems, {nv} variants drawn by "
        f"the sampler × {k} honest students per model = {nv * k:,} honest answers per answer and model (a "
        f"problem without random parameters: {nv * k:,} students of its one variant; an answer asked in "
        f"every case counts each case), {t_study:.0f} s. "
        + ("**Quick run: too few students to show a rate below 0.1 %; the full run does.** " if quick else "")
        + DRAWING_MODEL,
        "" if not skipped else "Skipped: " + "; ".join(skipped),
        md,
    ]
    if "ch5-ex5-3" in by_id:
        plots["tradeoff"] = PLOTS / "tradeoff_ch5-ex5-3_T.png"
        plot_tradeoff(by_id["ch5-ex5-3"], "T", plots["tradeoff"])
        plots["mc"] = PLOTS / "mc_stability.png"
        big = ts.simulate(bank["ch5-ex5-3"], 200 if quick else 1000, 30, seed=11, models=("sf3",))
        mc_md, mc_rows = mc_stability(big, "T", plots["mc"])
        md_parts += ["#### Monte-Carlo sample count against the derived tolerance", "", mc_md]
        data["mc"] = mc_rows
    plots["crank"] = PLOTS / "crank_resolution.png"
    cr_md, cr_rows = crank_resolution("ch5-ex5-1", plots["crank"], quick)
    md_parts += ["#### Crank-angle resolution of a full-cycle torque curve (Example 5.1)", "", cr_md]
    data["crank"] = cr_rows
    fig_md, fig_rows = figure_timing("ch5-ex5-3", 3 if quick else 7)
    md_parts += ["#### Figure format and resolution against time", "", fig_md]
    data["figures"] = fig_rows
    return {"name": "accuracy", "markdown": "\n\n".join(md_parts), "data": data, "plots": plots, "studies": studies}


if __name__ == "__main__":
    sys.stdout.write(run("--quick" in sys.argv)["markdown"] + "\n")
