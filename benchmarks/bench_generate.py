"""Throughput of `gradekit generate`: students per minute, sheets alone and with worked keys.

Run: ``python benchmarks/bench_generate.py [--quick]`` (quick: class size 30 only). Each line is
one configuration: class size, worker processes, whether keys are written, wall time and students
per minute (combined PDFs, key.csv and manifest included). Targets on a 2-core machine, judged on
the marginal rate between the two class sizes (start excluded): sheets alone >= 450/min (issue 13),
with worked keys >= 250/min (issue 24's floor; issue 13 had asked 300/min).
"""

from __future__ import annotations

import argparse
import logging
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("RAYON_NUM_THREADS", "1")  # Typst on one thread in `breakdown` too, as in a worker

from gradekit.documents import generate  # noqa: E402

ASSIGNMENT = ROOT / "examples" / "hw5.yaml"
NAMES = ["Selam Haile", "Chidi Okafor", "Zoë Łukasiewicz-Núñez", "Ana María Pérez", "Jonas Müller",
         "Mary O'Brien", "Nguyễn Văn An", "Olusegun Adeyemi"]
TARGETS = {False: 450.0, True: 250.0}  # students/min at the margin, 2 jobs (keys: issue 24's floor)


def roster(path: Path, n: int) -> Path:
    """A synthetic roster of *n* students (Latin names, some with diacritics)."""
    lines = ["student_id,name,email,section"]
    lines += [f"{10001 + i},{NAMES[i % len(NAMES)]},s{i}@example.edu,{'AB'[i % 2]}" for i in range(n)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (the pool's workers, once joined)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def measure(n: int, jobs: int, keys: bool, combine: bool = False) -> dict:
    """Generate for a class of *n* into a temporary folder; return timings: wall seconds and the CPU
    seconds of every process of the run (which other work on a shared machine inflates far less)."""
    with tempfile.TemporaryDirectory() as tmp:
        r = roster(Path(tmp) / "roster.csv", n)
        t0, c0 = time.perf_counter(), _cpu()
        generate(ASSIGNMENT, r, Path(tmp) / "out", jobs=jobs, keys=keys, progress=False)
        seconds, cpu = time.perf_counter() - t0, _cpu() - c0
        sizes = {name: (Path(tmp) / "out" / name).stat().st_size
                 for name in ("assignments.pdf", "keys.pdf") if (Path(tmp) / "out" / name).exists()}
        joined = combine_times(Path(tmp) / "out", n) if combine and keys and n >= 300 else None
    per_min = 60.0 * n / seconds
    return {"students": n, "jobs": jobs, "keys": keys, "seconds": round(seconds, 2), "cpu": round(cpu, 2),
            "per_minute": round(per_min, 1), "bytes": sizes, **({"combine": joined} if joined else {})}


def combine_times(out: Path, n: int) -> dict[int, float]:
    """Seconds to join the first n/3 and all n worked keys of a finished run into one PDF (as keys.pdf
    is made): the time a part must not grow with the class (it did, quadratically, before). In a run
    the main process joins each student's key as it arrives, beside the two workers, and writes the
    file after the last one."""
    from gradekit.documents import engine

    parts = sorted((out / "keys").glob("*.pdf"))
    times = {}
    for k in (n // 3, n):
        t = time.perf_counter()
        engine.concatenate_pdfs(out / "again.pdf", parts[:k], "again", "bench")
        times[k] = round(time.perf_counter() - t, 2)
    return times


def breakdown(n: int = 20) -> dict:
    """Where one worker's time goes: CPU seconds per student, in this process, of each part of a
    student's documents (examples/hw5.yaml, worked keys on), over *n* students after a first one
    (warm caches, as in a worker). Typst's share is split into layout and PDF export by compiling
    each body again without export (`query`). Apart: the main process's CPU a student for joining
    their sheet and key into the combined PDFs."""
    import shutil

    import typst

    from gradekit.assignment import class_keys, load_assignment
    from gradekit.documents import engine, typeset
    from gradekit.roster import read_roster, safe_names

    cpu = {"typst sheet": 0.0, "typst key": 0.0, "figures": 0.0, "template context": 0.0}
    bodies: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        students = read_roster(roster(Path(tmp) / "roster.csv", n + 1))
        names = safe_names({s.student_id: s for s in students})
        asg = load_assignment(ASSIGNMENT)
        _, variants = class_keys(asg, [s.student_id for s in students])
        out = Path(tmp) / "out"
        for sub in ("students", "keys", engine.BUILD):
            (out / sub).mkdir(parents=True)
        job = engine._Job(str(ASSIGNMENT), str(out), True, tuple(s.student_id for s in students))
        engine._init(job, asg, variants)
        pdf, pictures, context = typeset.Compiler.pdf, engine._pictures, engine.build_context

        def timed(key, f):
            def g(*a, **k):
                t = time.process_time()
                try:
                    return f(*a, **k)
                finally:
                    name = key(a) if callable(key) else key
                    if name:
                        cpu[name] += time.process_time() - t
            return g

        def body(a):
            bodies.append(a[1])
            return "typst key" if "WORKED KEY" in a[1] else "typst sheet"

        engine._one(students[0], names[students[0].student_id])
        typeset.Compiler.pdf = timed(body, pdf)
        engine._pictures = timed("figures", pictures)
        engine.build_context = timed("template context", context)
        try:
            t0 = time.process_time()
            for st in students[1:]:
                engine._one(st, names[st.student_id])
            total = time.process_time() - t0
        finally:
            typeset.Compiler.pdf, engine._pictures, engine.build_context = pdf, pictures, context
        # the main process's share: joining each student's sheet and key into the combined PDFs
        joins = {"assignments.pdf": engine.Joined("a", "b"), "keys.pdf": engine.Joined("k", "b")}
        t = time.process_time()
        for st in students[1:]:
            engine._join(joins, out, names[st.student_id])
        for name, joined in joins.items():
            joined.write(Path(tmp) / name)
        joining = time.process_time() - t
        layout = {"typst sheet": 0.0, "typst key": 0.0}
        for b in bodies:
            c = typst.Compiler(input=b.encode("utf-8"), root=str(out / engine.BUILD))
            t = time.process_time()
            c.query("heading")
            layout["typst key" if "WORKED KEY" in b else "typst sheet"] += time.process_time() - t
        shutil.rmtree(out, ignore_errors=True)
    per = {k: round(v / n, 4) for k, v in cpu.items()}
    per["other"] = round(total / n - sum(per.values()), 4)
    return {"students": n, "cpu_s_per_student": per, "total_cpu_s_per_student": round(total / n, 4),
            "typst_layout_s_per_student": {k: round(v / n, 4) for k, v in layout.items()},
            "join_cpu_s_per_student": round(joining / n, 4)}


def run(quick: bool, repeats: int = 3) -> dict:
    """Class sizes 30 and 300 (quick: 30 only), 2 jobs, keys off and on. The marginal rate between
    the two sizes, (300 − 30) / (t300 − t30), excludes the start (workers, bank loading).

    With keys (the target the runs come closest to) the pair is run *repeats* times, interleaved,
    and the median marginal rate is the figure: this machine's speed swings 10–15 % from one minute
    to the next, more than a single run can tell from a change of the code."""
    logging.getLogger("gradekit").setLevel(logging.ERROR)
    sizes = [30] if quick else [30, 300]
    results = []
    marginal = {}
    for keys in (False, True):
        rates, cpus = [], []
        for rep in range(repeats if keys and not quick else 1):
            pair = []
            for n in sizes:
                r = measure(n, 2, keys, combine=rep == 0) | {"run": rep + 1}
                # the machine is shared: the 1-minute load average at the end of each run says how busy
                r["load"] = round(os.getloadavg()[0], 2)
                results.append(r)
                pair.append(r)
                print(f"students={n:<4} jobs=2 keys={'yes' if keys else 'no ':<3} run {rep + 1} "
                      f"{r['seconds']:>7.2f} s  {r['per_minute']:>6.1f} students/min  CPU {r['cpu']:>7.2f} s  "
                      f"load {r['load']}", flush=True)
            if len(pair) == 2:
                a, b = pair
                rates.append(60.0 * (b["students"] - a["students"]) / (b["seconds"] - a["seconds"]))
                cpus.append((b["cpu"] - a["cpu"]) / (b["students"] - a["students"]))
        if rates:
            rate = statistics.median(rates)
            marginal["with keys" if keys else "sheets alone"] = {
                "per_minute": round(rate, 1), "target": TARGETS[keys], "meets": rate >= TARGETS[keys],
                "runs": [round(x, 1) for x in rates], "cpu_s_per_student": [round(x, 3) for x in cpus]}
            print(f"marginal, keys={'yes' if keys else 'no'}: {rate:.1f} students/min (runs {rates}; "
                  f"target {TARGETS[keys]:.0f}: {'met' if rate >= TARGETS[keys] else 'NOT met'}); CPU of all "
                  f"processes a student at the margin: {[round(x, 3) for x in cpus]} s", flush=True)
    parts = breakdown(5 if quick else 20)
    print(f"CPU a student in one worker: {parts['total_cpu_s_per_student']} s: {parts['cpu_s_per_student']}; "
          f"Typst layout alone {parts['typst_layout_s_per_student']}; joining a student's sheet and key into the "
          f"combined PDFs (main process) {parts['join_cpu_s_per_student']} s (load {os.getloadavg()[0]:.2f})",
          flush=True)
    combined = [r["combine"] for r in results if "combine" in r]
    if combined:
        print(f"keys.pdf from n/3 and n worked keys, s: {combined}", flush=True)
    return {"cpus": os.cpu_count(), "assignment": str(ASSIGNMENT.relative_to(ROOT)), "results": results,
            "marginal_per_minute": marginal, "breakdown": parts}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="class size 30 only")
    run(ap.parse_args().quick)


if __name__ == "__main__":
    main()
