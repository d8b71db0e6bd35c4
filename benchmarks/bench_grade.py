"""Grading end to end: the whole `gradekit grade` command a user runs, at 300 and 3,000 students.

For each class size the benchmark writes a roster, the keys `generate` would freeze (keys.json and
manifest.json for examples/hw5.yaml: 4 problems, 43 answers a student), and one submission per
student: most answers right to 4 significant figures, some wrong, some in other unit spellings, a
few blank or unreadable cells, and 5 % copied from a classmate. It then times the command in a fresh
process: with `--manifest` (the frozen keys) and without (keys re-derived for the class); and, for
what the command cannot do without, a fresh process that only starts as the command does, reads every
submission and writes the bytes of the frozen-keys run's outputs again (`_BARE`). Start-up
is excluded by the marginal rate between the two sizes: (3,000 − 300) / (t₃₀₀₀ − t₃₀₀). The time
includes reading every file, comparing, copy detection and writing grades.csv, canvas.csv,
moodle.csv, a feedback file per student, report.md and histogram.svg.

Run: ``python benchmarks/bench_grade.py [--quick]`` (quick: 100 and 1,000 students).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ASSIGNMENT = ROOT / "examples" / "hw5.yaml"


def prepare(folder: Path, n: int, seed: int = 373) -> None:
    """Roster, frozen keys, manifest and submissions of a class of *n* in *folder*."""
    from gradekit import frozen
    from gradekit.assignment import class_keys, load_assignment, manifest, seeds_of

    asg = load_assignment(ASSIGNMENT)
    ids = [f"{100000 + i}" for i in range(n)]
    with open(folder / "roster.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["student_id", "name", "email"])
        w.writerows([sid, f"Student {i}", f"s{i}@example.edu"] for i, sid in enumerate(ids))
    keys, variants = class_keys(asg, ids)
    text = frozen.dumps(keys)
    (folder / "gen").mkdir()
    (folder / "gen" / "keys.json").write_text(text, encoding="utf-8")
    seeds = {s: seeds_of(asg, s, {label: v.redraw for label, v in variants[s].items()}) for s in ids}
    (folder / "gen" / "manifest.json").write_text(json.dumps(manifest(asg, ids, seeds, text)), encoding="utf-8")
    by_student: dict[str, list] = {}
    for e in keys:
        by_student.setdefault(e.student_id, []).append(e)
    rng = random.Random(seed)
    subs = folder / "subs"
    subs.mkdir()
    for i, sid in enumerate(ids):
        source = ids[(i + 1) % n] if rng.random() < 0.05 else sid  # 5 % hand in a classmate's answers
        lines = ["student_id,key,value,unit"]
        for e in by_student[source]:
            roll = rng.random()
            v = e.value
            if roll < 0.75:
                lines.append(f"{sid},{e.key},{v:.4g},{e.unit}")
            elif roll < 0.85:
                lines.append(f"{sid},{e.key},{v * rng.uniform(0.5, 1.5):.4g},{e.unit}")
            elif roll < 0.9 and e.unit == "N*m":
                lines.append(f"{sid},{e.key},{v * 1000:.5g},N*mm")
            elif roll < 0.95:
                lines.append(f"{sid},{e.key},{-v:.4g},{e.unit}")
            elif roll < 0.98:
                lines.append(f"{sid},{e.key},,{e.unit}")
            else:
                lines.append(f"{sid},{e.key},abc,{e.unit}")
        (subs / f"{sid}_answers.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")


RUNS = 3  # of each configuration: this VM's disk and neighbours make single runs swing by ±30 %


def time_grade(folder: Path, manifest: bool, run: int = 0) -> float:
    """Seconds of the whole command `gradekit grade` (a fresh process) on *folder*'s class, into a
    new output folder (*run* numbers it)."""
    out = folder / f"{'graded-m' if manifest else 'graded'}-{run}"
    cmd = [sys.executable, "-m", "gradekit", "-q", "grade", str(ASSIGNMENT), "--roster", str(folder / "roster.csv"),
           "--submissions", str(folder / "subs"), "--out", str(out)]
    if manifest:
        cmd += ["--manifest", str(folder / "gen" / "manifest.json")]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if r.returncode != 0:
        raise RuntimeError(f"gradekit grade failed: {r.stderr[-2000:]}")
    rows = list(csv.DictReader((out / "grades.csv").open(encoding="utf-8")))
    assert len(rows) == len({r["student_id"] for r in rows}) == sum(1 for _ in (folder / "subs").iterdir())
    return seconds


# What the command costs before it grades anything, in a fresh process as the command runs: start-up
# (imports, the assignment, pint's registry), reading every submission's bytes, and writing the bytes
# of a finished run's outputs again into a new folder. What is left of the command's time is grading.
_BARE = """
import os, sys, time
t = time.perf_counter()
import gradekit.cli, gradekit.grading.batch
from gradekit import units
from gradekit.assignment import load_assignment
from gradekit.csvsafe import write_staged
load_assignment(sys.argv[1]); units.factor("N*mm", "N*m")
for e in os.scandir(sys.argv[2]):
    fd = os.open(e.path, os.O_RDONLY); os.read(fd, 2_000_000); os.close(fd)
start = time.perf_counter() - t
done, out = sys.argv[3], sys.argv[4]
files = [os.path.relpath(os.path.join(r, n), done) for r, _, names in os.walk(done) for n in names]
data = [open(os.path.join(done, f), "rb").read() for f in files]  # not timed: the command makes these
t = time.perf_counter()
for f, b in zip(files, data):
    os.makedirs(os.path.dirname(os.path.join(out, f)), exist_ok=True)
    write_staged(os.path.join(out, f), b)
print(start + time.perf_counter() - t)
"""


def time_bare(folder: Path, run: int = 0) -> float:
    """Seconds of start-up, reading and writing alone (`_BARE`) for *folder*'s class, the outputs
    those of its frozen-keys run *run*."""
    out = folder / f"bare-{run}"
    r = subprocess.run([sys.executable, "-c", _BARE, str(ASSIGNMENT), str(folder / "subs"),
                        str(folder / f"graded-m-{run}"), str(out)], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"the bare run failed: {r.stderr[-2000:]}")
    return float(r.stdout)


def create_cost(folder: Path, n: int = 300) -> float:
    """Microseconds to create an empty file in *folder* (the command creates two per student).

    On a disk other programs keep deleting files in (this machine's /tmp), ext4 without a journal
    passes over each recently freed inode before it reuses one: from about 20 µs to several hundred.
    """
    (folder / "create-cost").mkdir()
    t = time.perf_counter()
    for i in range(n):
        (folder / "create-cost" / str(i)).touch()
    return (time.perf_counter() - t) / n * 1e6


def run(quick: bool = False) -> dict:
    small, large = (100, 1_000) if quick else (300, 3_000)
    rows = []
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory(prefix="gradekit-bench-grade-") as tmp:
        create = create_cost(Path(tmp))
        for n in (small, large):
            folder = Path(tmp) / str(n)
            folder.mkdir()
            prepare(folder, n)
            times = {"manifest": [], "rederived": [], "bare": []}
            for i in range(RUNS if not quick else 1):  # interleaved, the median of each
                times["manifest"].append(time_grade(folder, True, i))
                times["bare"].append(time_bare(folder, i))
                times["rederived"].append(time_grade(folder, False, i))
            rows.append({"students": n, **{k: statistics.median(v) for k, v in times.items()}})
    load.append(os.getloadavg()[0])
    a, b = rows
    marginal = {k: (b["students"] - a["students"]) / (b[k] - a[k]) for k in ("manifest", "rederived", "bare")}
    ratio = {k: b[k] / a[k] for k in ("manifest", "rederived", "bare")}
    lines = [
        f"The whole command `gradekit grade` (fresh process) on examples/hw5.yaml (43 answers a student), "
        f"{small:,} and {large:,} students; marginal rate = ({large:,} − {small:,}) / (t{large} − t{small}). "
        f"Median of {RUNS if not quick else 1} runs of each, interleaved. "
        f"Load average (1 min) before and after: {load[0]:.2f}, {load[1]:.2f} on {os.cpu_count()} cores "
        f"(the command runs in one process); creating a file "
        f"in the folder took {create:,.0f} µs (about 20 µs on a quiet disk).",
        "",
        "| run | " + " | ".join(f"{r['students']:,} students" for r in rows) + " | marginal submissions/s "
        f"| t{large} / t{small} |",
        "|---|---|---|---|---|",
    ]
    for k, label in (("manifest", "frozen (`--manifest`)"), ("rederived", "re-derived for the class"),
                     ("bare", "start-up, reading and writing alone")):
        lines.append(f"| {label} | " + " | ".join(f"{r[k]:.1f} s" for r in rows)
                     + f" | {marginal[k]:,.0f} | {ratio[k]:.1f} |")
    return {"name": "grade", "rows": rows, "marginal": marginal, "ratio": ratio, "load": load, "create_us": create,
            "markdown": "\n".join(lines)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="100 and 1,000 students")
    print(run(parser.parse_args().quick)["markdown"])


if __name__ == "__main__":
    main()
