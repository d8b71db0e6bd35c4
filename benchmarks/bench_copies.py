"""Copy detection: independent students accused, copiers found, and time, at 300 and 3,000 students.

``python benchmarks/bench_copies.py [--sizes 300 3000] [--seed N]``

Keys are real: every student's variant of examples/hw5.yaml (4 problems, 43 answers) from
`gradekit.assignment.class_keys`, as `gradekit grade` builds them (cached per class size in the
system's temporary folder, since sampling 3,000 students takes about half a minute). Submissions
are synthetic, each kind by construction:

- honest: their key to 4 significant figures, 5 % of answers left blank or sign-flipped;
- small errors: every answer off by 1–3 of its own bands (wrong, but near their own key);
- guessers: every answer uniform over the class's range of keys for it, 4 significant figures;
- one wrong input: one problem's answers all ×1.1 (or ×0.9, ×1.2, ×0.8), the rest honest;
- sources: honest or one-wrong-input students whose answers a copier hands in (not counted as
  independent: a pair sharing wrong answers names both);
- copiers: a source's submission as is, with 1–2 answers changed, or re-rounded to 3 significant
  figures; a copier is found when a flag names them with their source.

Prints a markdown table per class size; the time is `find_copies` alone (median of 3).
"""

from __future__ import annotations

import argparse
import pickle
import random
import statistics
import tempfile
import time
from pathlib import Path

from gradekit.assignment import class_keys, load_assignment
from gradekit.grading.compare import StudentGrade, grade_student
from gradekit.grading.integrity import SHARED_WRONG, find_copies
from gradekit.grading.reader import Answer, Submission
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry

ROOT = Path(__file__).resolve().parent.parent
ASSIGNMENT = ROOT / "examples" / "hw5.yaml"
MIX = {"honest": 0.40, "small errors": 0.12, "guesser": 0.10, "one wrong input": 0.12, "source": 0.13, "copier": 0.13}
INDEPENDENT = ("honest", "small errors", "guesser", "one wrong input")


def real_keys(n: int) -> list[KeyEntry]:
    """Every student's key entries for hw5 (students S00000…), cached in the temporary folder."""
    cache = Path(tempfile.gettempdir()) / f"gradekit-bench-copies-keys-{n}.pickle"
    if cache.exists():
        try:
            return pickle.loads(cache.read_bytes())
        except Exception:  # noqa: BLE001 - a stale or partial cache is rebuilt
            pass
    asg = load_assignment(ASSIGNMENT)
    keys, _ = class_keys(asg, [f"S{i:05d}" for i in range(n)], with_mistakes=False)
    cache.write_bytes(pickle.dumps(keys))
    return keys


def sig(x: float, digits: int = 4) -> float:
    return float(f"{x:.{digits}g}")


def build_class(keys: list[KeyEntry], seed: int):
    """Assign kinds, write every student's answers and grade them: (grades, kind per id, source per copier)."""
    rng = random.Random(seed)
    entries: dict[str, list[KeyEntry]] = {}
    for e in keys:
        entries.setdefault(e.student_id, []).append(e)
    ids = list(entries)
    span: dict[str, tuple[float, float]] = {}
    for e in keys:
        lo, hi = span.get(e.key, (e.value, e.value))
        span[e.key] = (min(lo, e.value), max(hi, e.value))
    kinds = [kind for kind, share in MIX.items() for _ in range(round(share * len(ids)))]
    kinds += ["honest"] * (len(ids) - len(kinds))
    rng.shuffle(kinds)
    kind = dict(zip(ids, kinds, strict=True))
    values: dict[str, dict[str, float | None]] = {}

    def honest(e: KeyEntry) -> float | None:
        roll = rng.random()
        if roll < 0.025:
            return None
        return sig(-e.value if roll < 0.05 else e.value)

    for sid in ids:
        k, mine = kind[sid], entries[sid]
        if k == "guesser":
            values[sid] = {e.key: sig(rng.uniform(*span[e.key])) for e in mine}
        elif k == "small errors":
            values[sid] = {
                e.key: sig(e.value + rng.choice((-1, 1)) * rng.uniform(1, 3) * e.tolerance.band(e.value)) for e in mine
            }
        elif k in ("one wrong input", "source"):
            wrong = k == "one wrong input" or rng.random() < 0.5
            problem = rng.choice(sorted({e.problem for e in mine})) if wrong else None
            factor = rng.choice((1.1, 0.9, 1.2, 0.8))
            values[sid] = {e.key: sig(e.value * factor) if e.problem == problem else honest(e) for e in mine}
        elif k == "honest":
            values[sid] = {e.key: honest(e) for e in mine}
    sources = [s for s in ids if kind[s] == "source"]
    source_of: dict[str, str] = {}
    for sid in ids:
        if kind[sid] != "copier":
            continue
        src = rng.choice(sources)
        source_of[sid] = src
        copied = dict(values[src])
        how = rng.random()
        if how < 1 / 3:  # one or two answers changed
            for key in rng.sample(sorted(copied), rng.choice((1, 2))):
                copied[key] = sig(rng.uniform(*span[key]))
        elif how < 2 / 3:  # re-rounded
            copied = {key: None if v is None else sig(v, 3) for key, v in copied.items()}
        values[sid] = copied
    grades = []
    for sid in ids:
        answers = tuple(
            Answer(key, repr(v), "", v, "", line)
            for line, (key, v) in enumerate(values[sid].items(), start=2)
            if v is not None
        )
        grades.append(grade_student(Student(sid, sid), entries[sid], Submission(f"{sid}.csv", sid, answers)))
    return grades, kind, source_of


def measure(n: int, seed: int) -> dict:
    """Rates and time for one class of *n* students."""
    start = time.perf_counter()
    keys = real_keys(n)
    key_seconds = time.perf_counter() - start
    grades: list[StudentGrade]
    grades, kind, source_of = build_class(keys, seed)
    times, flags = [], []
    for _ in range(3):
        t = time.perf_counter()
        flags = find_copies(grades, keys)
        times.append(time.perf_counter() - t)
    accused: dict[str, set[str]] = {}
    for f in flags:
        accused.setdefault(f.student_id, set()).add(f.other_id)
        if f.reason == SHARED_WRONG:
            accused.setdefault(f.other_id, set()).add(f.student_id)
    rows = {}
    for k in (*INDEPENDENT, "source"):
        members = [s for s in kind if kind[s] == k]
        rows[k] = (sum(s in accused for s in members), len(members))
    copiers = list(source_of)
    found = sum(source_of[s] in accused.get(s, ()) for s in copiers)
    by_reason = {reason: sum(1 for f in flags if f.reason == reason) for reason in sorted({f.reason for f in flags})}
    return {
        "n": n,
        "rows": rows,
        "found": (found, len(copiers)),
        "seconds": statistics.median(times),
        "key_seconds": key_seconds,
        "flags": len(flags),
        "by_reason": by_reason,
    }


def table(results: list[dict]) -> str:
    def rate(pair: tuple[int, int]) -> str:
        a, b = pair
        return f"{100 * a / b:.1f} % ({a}/{b})" if b else "–"

    head = "| | " + " | ".join(f"{r['n']:,} students" for r in results) + " |"
    lines = [head, "|---|" + "---|" * len(results)]
    for k in INDEPENDENT:
        lines.append(f"| accused: {k} | " + " | ".join(rate(r["rows"][k]) for r in results) + " |")
    independent = [
        (sum(r["rows"][k][0] for k in INDEPENDENT), sum(r["rows"][k][1] for k in INDEPENDENT)) for r in results
    ]
    lines.append(
        "| **accused: all independent** (goal ≤ 1 %) | " + " | ".join(f"**{rate(p)}**" for p in independent) + " |"
    )
    lines.append(
        "| **copiers found, source named** (goal ≥ 90 %) | "
        + " | ".join(f"**{rate(r['found'])}**" for r in results)
        + " |"
    )
    lines.append(
        "| sources named (a pair sharing wrong answers names both) | "
        + " | ".join(rate(r["rows"]["source"]) for r in results)
        + " |"
    )
    lines.append(
        "| flags (by reason) | "
        + " | ".join(
            f"{r['flags']} (" + ", ".join(f"{k}: {v}" for k, v in r["by_reason"].items()) + ")" for r in results
        )
        + " |"
    )
    lines.append("| `find_copies` time (median of 3) | " + " | ".join(f"{r['seconds']:.2f} s" for r in results) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[300, 3000])
    parser.add_argument("--seed", type=int, default=373)
    args = parser.parse_args()
    results = [measure(n, args.seed) for n in args.sizes]
    print(table(results))


if __name__ == "__main__":
    main()
