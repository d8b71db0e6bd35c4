"""Grading throughput: synthetic submissions read and compared per second (feedback files aside)."""

from __future__ import annotations

import argparse
import random
import statistics
import tempfile
import time
from pathlib import Path

from gradekit.grading.batch import grade_students, read_submissions
from gradekit.keys import KeyEntry, Tolerance
from gradekit.roster import Student

UNITS = ["N*m", "N", "N", "N", "N", "m/s**2", "rad/s**2", "N", "N*m", "rad"]


def build(folder: Path, n: int, seed: int = 373) -> tuple[list[KeyEntry], list[Student]]:
    """Write *n* submissions (10 answers each, a realistic mix of spellings) and their keys."""
    rng = random.Random(seed)
    keys: list[KeyEntry] = []
    students: list[Student] = []
    for i in range(n):
        sid = f"{100000 + i}"
        students.append(Student(sid, f"Student {i}"))
        lines = ["student_id,key,value,unit"]
        for j, unit in enumerate(UNITS):
            value = rng.uniform(-500, 500)
            key = f"p{j // 4 + 1}.a{j}"
            keys.append(KeyEntry(sid, f"p{j // 4 + 1}", key, value, unit, Tolerance("relative", rel=0.01)))
            roll = rng.random()
            if roll < 0.6:
                lines.append(f"{sid},{key},{value:.4g},{unit}")
            elif roll < 0.7 and unit == "N*m":
                lines.append(f"{sid},{key},{value * 1000:.5g} N*mm,")
            elif roll < 0.8:
                lines.append(f"{sid},{key},{-value:.3e},{unit}")
            elif roll < 0.9:
                lines.append(f"{sid},{key}, {value * 1.2:.4f} ,")
            else:
                lines.append(f"{sid},{key},abc,{unit}")
        (folder / f"s{sid}_answers.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return keys, students


def run(quick: bool = False) -> dict:
    """Measure submissions graded per second (reading + comparing), median of several runs.

    Args:
        quick: 1,000 submissions and 3 runs instead of 10,000 and 5.

    Returns:
        ``{"name", "submissions", "runs", "per_second", "seconds"}``.
    """
    n, runs = (1_000, 3) if quick else (10_000, 5)
    with tempfile.TemporaryDirectory(prefix="gradekit-bench-") as tmp:
        folder = Path(tmp)
        keys, students = build(folder, n)
        times = []
        for _ in range(runs):
            start = time.perf_counter()
            intake = read_submissions(folder, students, keys)
            grades = grade_students(keys, students, intake.chosen)
            times.append(time.perf_counter() - start)
            assert sum(g.submission is not None for g in grades) == n
    seconds = statistics.median(times)
    return {"name": "grade", "submissions": n, "runs": runs, "per_second": n / seconds, "seconds": seconds}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="1,000 submissions, 3 runs")
    result = run(parser.parse_args().quick)
    print(f"grade: {result['per_second']:,.0f} submissions/s (median of {result['runs']} runs)")


if __name__ == "__main__":
    main()
