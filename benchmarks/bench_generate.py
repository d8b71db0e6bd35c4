"""Throughput of `gradekit generate`: students per minute, sheets alone and with worked keys.

Run: ``python benchmarks/bench_generate.py [--quick]`` (quick: class size 30 only). Each line is
one configuration: class size, worker processes, whether keys are written, wall time and students
per minute (combined PDFs, key.csv and manifest included). Targets on a 2-core machine, judged on
the marginal rate between the two class sizes (start excluded): sheets alone >= 450/min, with
worked keys >= 300/min (issue 13).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gradekit.documents import generate  # noqa: E402

ASSIGNMENT = ROOT / "examples" / "hw5.yaml"
NAMES = ["Selam Haile", "Chidi Okafor", "Zoë Łukasiewicz-Núñez", "Ana María Pérez", "Jonas Müller",
         "Mary O'Brien", "Nguyễn Văn An", "Olusegun Adeyemi"]
TARGETS = {False: 450.0, True: 300.0}  # students/min at the margin, 2 jobs


def roster(path: Path, n: int) -> Path:
    """A synthetic roster of *n* students (Latin names, some with diacritics)."""
    lines = ["student_id,name,email,section"]
    lines += [f"{10001 + i},{NAMES[i % len(NAMES)]},s{i}@example.edu,{'AB'[i % 2]}" for i in range(n)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def measure(n: int, jobs: int, keys: bool) -> dict:
    """Generate for a class of *n* into a temporary folder; return timings."""
    with tempfile.TemporaryDirectory() as tmp:
        r = roster(Path(tmp) / "roster.csv", n)
        t0 = time.perf_counter()
        generate(ASSIGNMENT, r, Path(tmp) / "out", jobs=jobs, keys=keys, progress=False)
        seconds = time.perf_counter() - t0
        sizes = {name: (Path(tmp) / "out" / name).stat().st_size
                 for name in ("assignments.pdf", "keys.pdf") if (Path(tmp) / "out" / name).exists()}
    per_min = 60.0 * n / seconds
    return {"students": n, "jobs": jobs, "keys": keys, "seconds": round(seconds, 2),
            "per_minute": round(per_min, 1), "bytes": sizes}


def run(quick: bool) -> dict:
    """Class sizes 30 and 300 (quick: 30 only), 2 jobs, keys off and on. The marginal rate between
    the two sizes, (300 − 30) / (t300 − t30), excludes the start (workers, bank loading)."""
    logging.getLogger("gradekit").setLevel(logging.ERROR)
    sizes = [30] if quick else [30, 300]
    results = []
    for n in sizes:
        for keys in (False, True):
            for jobs in (2,):
                r = measure(n, jobs, keys)
                results.append(r)
                print(f"students={n:<4} jobs={jobs} keys={'yes' if keys else 'no ':<3} "
                      f"{r['seconds']:>7.2f} s  {r['per_minute']:>6.1f} students/min", flush=True)
    marginal = {}
    for keys in (False, True):
        rows = [r for r in results if r["keys"] == keys]
        if len(rows) == 2:
            (a, b) = rows
            rate = 60.0 * (b["students"] - a["students"]) / (b["seconds"] - a["seconds"])
            marginal["with keys" if keys else "sheets alone"] = {
                "per_minute": round(rate, 1), "target": TARGETS[keys], "meets": rate >= TARGETS[keys]}
            print(f"marginal, keys={'yes' if keys else 'no'}: {rate:.1f} students/min "
                  f"(target {TARGETS[keys]:.0f}: {'met' if rate >= TARGETS[keys] else 'NOT met'})", flush=True)
    return {"cpus": os.cpu_count(), "assignment": str(ASSIGNMENT.relative_to(ROOT)), "results": results,
            "marginal_per_minute": marginal}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="class size 30 only")
    run(ap.parse_args().quick)


if __name__ == "__main__":
    main()
