"""Both sides of every band: honest work admitted, wrong answers rejected (issue 25).

    python benchmarks/discrimination.py [--variants 300] [--students 10] [--class-only] [--write]

Per answer of every bank problem, at the band the grader applies (the bank as loaded: the file's
``constraints.bands`` through ``_tolerances.yaml``):

* the honest false-reject rate of every honest model the sheet asks for (`tolerance_study.simulate`,
  the grader's own `Tolerance.accepts_many`), with its one-sided 95 % Clopper–Pearson upper bound;
* the share of variants in which an answer 5 % and 10 % off (a direction 2° and 5° off:
  `gradekit.solving.tolerances.off_by`) still earns full credit;
* the share of variants in which each catalogued mistake (`gradekit.solving.mistakes`) and each generic
  one (sign, ×/÷1000, degrees/radians) still earns full credit.

And the class test of the issue: one assignment holding every bank problem (10 points each, shared
by the answers' points), a class of 300 whose every automatically graded answer is 10 % off
(5 % and 20 % beside it); the share of the points the class keeps and that the key keeps. Answers
marked ``hand_check`` are not graded automatically and count for neither.

``--write`` replaces the "Discrimination" section of benchmarks/RESULTS.md with the tables.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import tolerance_study as ts  # noqa: E402

from gradekit.bank.registry import load_bank  # noqa: E402
from gradekit.figures.sheet import printed_scale  # noqa: E402
from gradekit.solving.sampling import derive_seed, sample_many  # noqa: E402
from gradekit.solving.tolerances import (  # noqa: E402
    DISCRIMINATION_MIN,
    FALSE_REJECT_MAX,
    OFF_FAR,
    OFF_NEAR,
    accepted_off,
    band_text,
    is_direction,
    mistake_gradable,
    mistake_size,
)

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"
# The class test on the bank before issue 25's bands (commit 576afb4, `--class-only`): key, 5 %, 10 %, 20 % off.
BEFORE = ("100.0 %", "67.5 %", "45.4 %", "18.6 %")
SECTION = "## Discrimination: honest work admitted, wrong answers rejected"
CLASS = 300
PROBLEM_POINTS = 10.0


def class_share(problems: dict, off: tuple[float, float] | None, students: int = CLASS) -> dict[str, tuple]:
    """Per problem (points kept, points) of a class of *students* whose every automatically graded answer
    is *off* (None: the key itself), each problem worth `PROBLEM_POINTS` shared by its answers' points."""
    out = {}
    for pid, p in sorted(problems.items()):
        graded = [a for a in p.answers if not a.hand_check and a.points > 0]
        if not graded:
            out[pid] = (0.0, 0.0)
            continue
        randoms = any(q.random for q in p.parameters.values())
        seeds = [derive_seed("MEG373", "issue-25", f"s{i:04d}", pid) for i in range(students)] if randoms else [None]
        vb = sample_many(p, seeds)
        total_w = sum(a.points for a in graded)
        kept = 0.0
        for batch, rows in vb.by_batch():
            sel = np.asarray(rows)
            for a in batch.answer_list:
                if a.spec.hand_check or a.spec.points <= 0:
                    continue
                n_case = sum(1 for b in batch.answer_list if b.spec is a.spec)
                w = PROBLEM_POINTS * a.spec.points / total_w / n_case
                vals, sc = a.value[sel], a.scale[sel]
                tol = a.spec.tolerance
                ok = tol.accepts_many(vals, vals, sc) if off is None else accepted_off(tol, vals, sc, a.unit, off)
                kept += w * float(ok.sum()) / len(vb)  # every student's share (one batch may hold several)
        out[pid] = (kept if randoms else kept * len(vb), PROBLEM_POINTS)
    return out


def class_table(problems: dict) -> str:
    offs = {"key": None, "5 % off": (0.05, 2.0), "10 % off": OFF_FAR, "20 % off": (0.20, 10.0)}
    shares = {name: class_share(problems, off) for name, off in offs.items()}
    lines = ["| problem | " + " | ".join(offs) + " |", "|---|" + "---|" * len(offs)]
    for pid in sorted(problems):
        cells = []
        for name in offs:
            k, t = shares[name][pid]
            cells.append(f"{100 * k / t:.1f} %" if t else "—")
        lines.append(f"| {pid} | " + " | ".join(cells) + " |")
    tot = []
    for name in offs:
        k = sum(v[0] for v in shares[name].values())
        t = sum(v[1] for v in shares[name].values())
        tot.append(f"**{100 * k / t:.1f} %**")
    lines.append("| **assignment of every bank problem** | " + " | ".join(tot) + " |")
    return "\n".join(lines)


def sampling_table(problems: dict, students: int = CLASS) -> str:
    """Per problem: the mean draws a student's variant takes with every rule and without the
    gradability rule (``gradable`` 0, no ``distinguish``), the share of draws the rule rejects, and the
    time `sample_many` takes for a class of *students* both ways."""
    lines = [
        "| problem | draws a variant, all rules | without the gradability rule | rejected by the rule | "
        f"class of {students} drawn, all rules | without |",
        "|---|---|---|---|---|---|",
    ]
    for pid, p in sorted(problems.items()):
        if not any(q.random for q in p.parameters.values()):
            lines.append(f"| {pid} | published values only | — | — | — | — |")
            continue
        seeds = [derive_seed("MEG373", "issue-25", f"s{i:04d}", pid) for i in range(students)]
        relaxed = replace(p, constraints=replace(p.constraints, gradable=0.0, distinguish=()))
        out = []
        for q in (p, relaxed):
            t = time.perf_counter()
            vb = sample_many(q, seeds)
            out.append((float(vb.draws[vb.ok].mean()), time.perf_counter() - t))
        (d_all, t_all), (d_rel, t_rel) = out
        lines.append(f"| {pid} | {d_all:.2f} | {d_rel:.2f} | {1 - d_rel / d_all:.1%} | {t_all:.2f} s | {t_rel:.2f} s |")
    return "\n".join(lines)


def hand_rows(st: ts.Study) -> list[str]:
    """Each answer marked hand_check with the honest spread that leaves no band: the 99.9th percentile of
    the honest error (relative; degrees for a direction) of its worst model, and where it is reached."""
    out = []
    specs = {a.key: a for a in st.problem.answers}
    for key, a in st.answers.items():
        if not specs[key].hand_check:
            continue
        worst = (0.0, "")
        for m in st.models:
            d = a.honest[m] - a.exact[:, None]
            if a.kind == "angle":
                e = np.abs((d + 180.0) % 360.0 - 180.0)
            else:
                with np.errstate(divide="ignore", invalid="ignore"):
                    e = np.abs(d) / np.abs(a.exact[:, None])
            q = float(np.nanpercentile(e, 99.9))
            worst = max(worst, (q, m))
        size = f"{worst[0]:.2g}°" if a.kind == "angle" else f"{100 * worst[0]:.3g} %"
        out.append(f"| {st.problem.id} | {key} | {worst[1]} | {size} |")
    return out


def _size(med: float, direction: bool) -> str:
    return f"{med:.2g}°" if direction else f"{100 * med:.2g} %"


def _fmt_share(x: float) -> str:
    return "—" if x != x else f"{100 * x:.1f} %"


def answer_rows(st: ts.Study) -> list[dict]:
    """One row per answer of a study: honest bound, 5 %/10 % off and every mistake's pass share."""
    out = []
    specs = {a.key: a for a in st.problem.answers}
    models = st.models
    for key, a in st.answers.items():
        spec = specs[key]
        tol = spec.tolerance
        s = ts.evaluate(a, tol, models)
        near = float(accepted_off(tol, a.exact, a.scale, a.unit, OFF_NEAR).mean())
        far = float(accepted_off(tol, a.exact, a.scale, a.unit, OFF_FAR).mean())
        mistakes = {}
        for name, rate in s.detection.items():
            vals = a.mistakes[name]
            live = np.isfinite(vals) & np.isfinite(a.exact)
            size = mistake_size(tol, vals[live], a.exact[live], a.unit)
            big = np.array([mistake_gradable(float(x), a.unit) for x in size], bool)
            ok = tol.accepts_many(vals[live], a.exact[live], a.scale[live])
            big_share = float(ok[big].mean()) if big.any() else 0.0
            mistakes[name] = (1.0 - rate, float(np.median(size)), big_share)
        out.append(
            {
                "key": key,
                "unit": a.unit,
                "band": tol,
                "hand": spec.hand_check,
                "ub": s.worst_bound(),
                "rejected": {m: (s.rejected[m], s.samples[m]) for m in s.samples},
                "near": near,
                "far": far,
                "mistakes": mistakes,
                "direction": is_direction(a.unit),
            }
        )
    return out


def problem_table(st: ts.Study, rows: list[dict]) -> str:
    models = st.models
    head = ["answer", "band", *(f"honest rejected {m}" for m in models), "95 % bound", "5 % / 2° off passes",
            "10 % / 5° off passes", "mistakes still passing (share of variants)", "goals"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        rej = [f"{r['rejected'][m][0]}/{r['rejected'][m][1]}" if m in r["rejected"] else "—" for m in models]
        passing = [
            f"{n} {_fmt_share(x)} (median size {_size(med, r['direction'])}; where over 10 % / 5°: {_fmt_share(big)})"
            for n, (x, med, big) in sorted(r["mistakes"].items(), key=lambda t: -t[1][0])
            if x > 0
        ]
        goal = verdict(r)
        lines.append(
            f"| {r['key']} | {band_text(r['band'])} | " + " | ".join(rej) + f" | {100 * r['ub']:.3f} % | "
            f"{_fmt_share(r['near'])} | {_fmt_share(r['far'])} | {'; '.join(passing) or 'none'} | {goal} |"
        )
    return "\n".join(lines)


def verdict(r: dict) -> str:
    if r["hand"]:
        return "hand check"
    bad = []
    if r["ub"] >= FALSE_REJECT_MAX:
        bad.append("honest")
    if r["far"] > 1 - DISCRIMINATION_MIN:
        bad.append("10 % off")
    missed = [n for n, (_x, _med, big) in r["mistakes"].items() if big > 1 - DISCRIMINATION_MIN]
    if missed:
        bad.append("mistake: " + ", ".join(sorted(missed)))
    return "ok" if not bad else "MISSES " + "; ".join(bad)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", type=int, default=300)
    ap.add_argument("--students", type=int, default=10)
    ap.add_argument("--class-only", action="store_true")
    ap.add_argument("--only", default="", help="comma-separated problem ids")
    ap.add_argument("--write", action="store_true", help="write the section of benchmarks/RESULTS.md")
    args = ap.parse_args()
    t0 = time.perf_counter()
    problems = load_bank()
    if args.only:
        problems = {k: v for k, v in problems.items() if k in args.only.split(",")}
    ct = class_table(problems)
    print(ct)
    print(f"(class: {time.perf_counter() - t0:.1f} s)")
    if args.class_only:
        return
    parts = []
    summary = []
    hands: list[str] = []
    for pid, p in sorted(problems.items()):
        t = time.perf_counter()
        st = ts.simulate(p, args.variants, args.students, printed_scale=printed_scale)
        rows = answer_rows(st)
        hands += hand_rows(st)
        tab = problem_table(st, rows)
        ok = sum(verdict(r) in ("ok", "hand check") for r in rows)
        summary.append((pid, len(rows), ok, sum(r["hand"] for r in rows)))
        parts.append(f"#### {pid} ({st.method}, {st.variants} variants × {st.per_variant} students a model)\n\n{tab}")
        print(f"\n{pid}: {time.perf_counter() - t:.1f} s\n{tab}", flush=True)
    samp = sampling_table(problems)
    import bench_solver  # the lead's solver benchmark: the sampler's rule adds nothing to solve_many

    sv = bench_solver.bank_problem("ch5-ex5-3", 100_000, 3)
    samp += (
        f"\n\n`solve_many` on ch5-ex5-3 (`bench_solver.bank_problem`, 100,000 variants, median of 3, this run): "
        f"{sv['per_second']:,.0f} variants/s against a bare batched `numpy.linalg.solve` of the same systems of "
        f"{sv['ceiling_per_second']:,.0f}/s, on this machine shared with other work at the time (the Solver "
        "throughput section measured 116,964 of 964,334 on a quieter one; `python benchmarks/run.py "
        "--only=bench_solver` re-measures it). The gradability rule runs in the sampler's `check_many` on the "
        "solved batch (a band comparison per answer, and for graphical problems the torque shares from the "
        "forces already solved), never inside `solve_many`."
    )
    print(samp)
    if args.write:
        write(ct, parts, summary, hands, samp, args, time.perf_counter() - t0)


def write(ct: str, parts: list[str], summary: list, hands: list[str], samp: str, args, seconds: float) -> None:
    head = [
        SECTION,
        "",
        f"`python benchmarks/discrimination.py --variants {args.variants} --students {args.students} --write` "
        f"({time.strftime('%Y-%m-%d %H:%M')}, {seconds:.0f} s).",
        "",
        "### A class whose every answer is off",
        "",
        f"One assignment holding every bank problem ({PROBLEM_POINTS:g} points each, shared by its answers' "
        f"points), {CLASS} students (`sample_many` with each student's seed), every automatically graded answer "
        "moved by the share (a direction by the degrees) in the column, graded at the band the grader applies; "
        "answers marked `hand_check` count for neither side. "
        "`python benchmarks/discrimination.py --class-only` prints it.",
        "",
        ct,
        "",
        f"Before these bands (the bank of commit 576afb4, same command): key {BEFORE[0]}, 5 % off {BEFORE[1]}, "
        f"10 % off {BEFORE[2]}, 20 % off {BEFORE[3]} (the issue measured 45.7 % on the keys of a generated class).",
        "",
        "### How the bands were made to grade",
        "",
        "* **Gradability rule** (`constraints.gradable`, default 10.5, `gradekit/solving/sampling.py`): every "
        "automatically "
        "graded answer is at least 10.5 bands from zero, so no band is wider than 9.5 % of its answer and an answer "
        "10 % off never earns credit. A band is `rel·|answer|` plus a floor, a fraction of the variant's scale (its "
        "largest answer of the same dimension): the floor is the honest error of the whole construction, measured. "
        "Where an answer is a small difference of large numbers, a superposition part the others nearly cancel, or "
        "a component a few percent of the forces around it, the floor is more than 9.5 % of it and the draw is "
        "rejected. For graphical problems, a torque under `ARM_MIN` = 0.51 of the moment its polygon's largest force "
        "would have at the crank pin (a polygon whose sides are nearly parallel to the crank) is rejected too. One "
        "rule for every problem; the numbers it uses are each answer's measured band.",
        "* **Bands** (`python benchmarks/derive_tolerances.py --bands`, then the table without `--bands`): per "
        "answer, over the honest-student study of the problem without the rule, the band of at most 1/10.5 of the "
        "answer that admits honest work (95 % bound < 0.1 %) in the most variants, then the narrowest.",
        "* **Precision asked**: the analytical problems ask for 4 significant figures (`sigfigs: 4`, printed in "
        "their statements; the study admits 4- and 5-figure work); every graphical statement prints the reading "
        "accuracy the drawing model assumes (lengths to 0.5 mm, directions to 0.5°, polygons 60–150 mm).",
        "* **Hand checking** where no band does both (below): `hand_check: true` on the answer.",
        "",
        "### Answers checked by hand",
        "",
        "No band both admits honest work (95 % bound below 0.1 %) and stays under 1/10.5 of the answer in "
        "enough draws (`benchmarks/derive_tolerances.py --bands`): the honest spread below is the 99.9th "
        "percentile of the honest error of the answer's worst honest model over the draws the sampler makes. "
        "These answers carry `hand_check: true`; they are not graded automatically.",
        "",
        "| problem | answer | worst honest model | honest error, 99.9th percentile |",
        "|---|---|---|---|",
        *(hands or ["| — | — | — | — |"]),
        "",
        "### What the gradability rule rejects, and what sampling costs",
        "",
        "`sample_many` for a class, with every rule of the problem and with the gradability rule switched off "
        "(`gradable: 0`, no `distinguish`): mean draws per accepted variant, the share of draws the rule "
        "rejects (1 − the ratio), and the wall time of the class on this shared 2-core machine.",
        "",
        samp,
        "",
        "### Per answer",
        "",
        "Goals (issue 25): honest false-reject 95 % bound < 0.1 %; an answer 10 % off (a direction 5° off) "
        "earns full credit in ≤ 5 % of the variants; each catalogued or generic mistake in ≤ 5 % of the variants "
        "where it moves the answer more than 10 % (5°). Where a mistake still passes, the reason is its size: in "
        "those variants it moves the answer less than the 10 % a band must reject (the median size is given; "
        "e.g. gravity beside inertia forces hundreds of times larger), so no band that admits honest work sees it.",
        "",
        "| problem | answers | meeting every goal | hand check |",
        "|---|---|---|---|",
        *(f"| {pid} | {n} | {ok} | {h} |" for pid, n, ok, h in summary),
        "",
        *("\n\n".join(parts).splitlines()),
        "",
    ]
    text = RESULTS.read_text(encoding="utf-8")
    block = "\n".join(head)
    pat = re.compile(re.escape(SECTION) + r".*?(?=\n## |\Z)", re.S)
    text = pat.sub(lambda _m: block.rstrip() + "\n", text) if pat.search(text) else text.rstrip() + "\n\n" + block
    RESULTS.write_text(text, encoding="utf-8")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
