"""`gradekit generate --student`: the cost of adding one late student to a generated class of n.

Run: ``python benchmarks/bench_student.py [--quick] [--sizes 300,3000]`` (quick: 300 only). A class of
n is made as generate leaves it (keys.json, manifest.json and listing of the whole class, drawn in
class batches) with every student's sheet and key a hard link to one real student's, then one late
student is added in a fresh process, as an instructor runs it. Each line: class size, wall seconds,
peak memory (MB) of that process, and the seconds of the step that does not depend on the class's
PDFs (drawing, solving and typesetting the student, keys.json merged; measured with the combined
PDFs' step left out by a roster of one in an empty folder). Issue 26 item 1: only the student is
drawn and solved; the combined PDFs are rebuilt, which is the part that grows with the class.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gradekit import frozen  # noqa: E402
from gradekit.api import generate  # noqa: E402
from gradekit.assignment import class_keys, load_assignment, manifest, seeds_of  # noqa: E402
from gradekit.documents.engine import LISTING  # noqa: E402

ASSIGNMENT = 'title: "Bench"\ncourse: MEG373\nsalt: "bench-student"\nproblems:\n  - {id: ch5-ex5-1, points: 10}\n'


def make_class(base: Path, n: int) -> Path:
    """A generated class of *n* in base/out, every document linked to one real student's."""
    (base / "hw.yaml").write_text(ASSIGNMENT, encoding="utf-8")
    ids = [f"s{i:05d}" for i in range(n)]
    (base / "one.csv").write_text(f"student_id,name\n{ids[0]},Name {ids[0]}\n", encoding="utf-8")
    generate(base / "hw.yaml", base / "one.csv", base / "seed")
    asg = load_assignment(base / "hw.yaml")
    entries, variants = class_keys(asg, ids)
    text = frozen.dumps(entries)
    out = base / "out"
    (out / "keys").mkdir(parents=True)
    (out / frozen.FILE).write_text(text, encoding="utf-8")
    seeds = {s: seeds_of(asg, s, {label: v.redraw for label, v in variants[s].items()}) for s in ids}
    data = manifest(asg, ids, seeds, text)
    (out / "manifest.json").write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    files = [frozen.FILE, "manifest.json"]
    for s in ids:
        (out / "students" / s).mkdir(parents=True)
        for name in ("assignment.pdf", "answers.csv"):
            os.link(base / "seed" / "students" / ids[0] / name, out / "students" / s / name)
            files.append(f"students/{s}/{name}")
        os.link(base / "seed" / "keys" / f"{ids[0]}.pdf", out / "keys" / f"{s}.pdf")
        files.append(f"keys/{s}.pdf")
    (out / LISTING).write_text("gradekit generate output\n" + "\n".join(sorted(files)) + "\n", encoding="utf-8")
    (base / "late.csv").write_text("student_id,name\nlate1,Late Student\n", encoding="utf-8")
    return out


def add_late(base: Path, out: Path) -> tuple[float, float]:
    """Wall seconds and peak memory (MB) of ``generate --student late1`` into *out*, in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "gradekit", "-q", "generate", str(base / "hw.yaml"), "--roster",
                    str(base / "late.csv"), "--out", str(out), "--student", "late1"], check=True)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return seconds, max(peak, before) / 1024


def measure(n: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        out = make_class(base, n)
        seconds, peak = add_late(base, out)
        alone, _ = add_late(base, base / "alone")  # the same student into an empty folder: no class PDFs
        data = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
        assert len(data["students"]) == n + 1
    return {"students": n, "seconds": round(seconds, 2), "peak_mb": round(peak), "student_alone_s": round(alone, 2)}


def run(quick: bool = False, sizes: tuple[int, ...] = (300, 3000)) -> dict:
    rows = [measure(n) for n in ((300,) if quick else sizes)]
    return {"generate --student": rows}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--sizes", default="300,3000")
    args = parser.parse_args()
    for row in run(args.quick, tuple(int(x) for x in args.sizes.split(",")))["generate --student"]:
        print(json.dumps(row))
