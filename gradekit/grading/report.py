"""The instructor's grading report (report.md) and its score histogram."""

from __future__ import annotations

import statistics
from collections import Counter
from collections.abc import Sequence
from itertools import chain, compress, repeat
from operator import is_, is_not
from pathlib import Path

from gradekit.grading.compare import StudentGrade
from gradekit.grading.feedback import md_cell
from gradekit.grading.integrity import IntegrityFlag


def write_histogram(path: Path, percents: Sequence[float], title: str) -> None:
    """A histogram of the scores (percent, 10 % bins), saved as PNG without pyplot."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 3.5))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    # 100.00000000000001 % is a perfect score: clamp round-off into the last bin (its edge is closed)
    ax.hist([min(max(p, 0.0), 100.0) for p in percents], bins=[10.0 * i for i in range(11)], edgecolor="black")
    ax.set_xlabel("score (%)")
    ax.set_ylabel("students")
    ax.set_title(title, parse_math=False)  # the instructor's words as written: "$5 late fee" is no formula
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, format="png", dpi=100)
    tmp.replace(path)


def report_markdown(
    *,
    assignment_title: str,
    grades: Sequence[StudentGrade],
    files: Sequence[tuple[str, str, str]],
    flags: Sequence[IntegrityFlag],
    histogram: str | None,
    carried: bool = False,
    carry_limits: Sequence[tuple[str, str]] = (),
    attention: str = "",
) -> str:
    """The instructor's report: summary, (*attention*: what to check first,) item analysis, (answers
    carried forward,) integrity flags, file accounting."""
    submitted = [g for g in grades if g.submission is not None]
    percents = [g.percent for g in submitted]
    out = [f"# {md_cell(assignment_title)}: grading report", ""]
    out += [
        f"- students on the roster: {len(grades)}",
        f"- graded submissions: {len(submitted)}",
        f"- missing: {len(grades) - len(submitted)}",
    ]
    if percents:
        out += [
            f"- mean score: {statistics.fmean(percents):.1f} %",
            f"- median score: {statistics.median(percents):.1f} %",
        ]
    out.append("")
    if histogram:
        out += [f"![Score histogram]({histogram})", ""]
    out += [
        "## Item analysis",
        "",
        "| Answer | Right | Answered | Most common mistakes |",
        "|---|---|---|---|",
    ]
    # per answer key, one pass over the class's columns each (counted in C): results, right, unanswered,
    # and the names of the mistakes diagnosed in the order met
    columns = [g.columns() for g in submitted]
    keys = list(chain.from_iterable(c.keys for c in columns))
    totals = Counter(keys)  # (in the order the keys are first met)
    rights = Counter(compress(keys, chain.from_iterable(c.correct for c in columns)))
    blanks = Counter(compress(keys, map(is_, chain.from_iterable(c.values for c in columns), repeat(None))))
    diagnoses = list(chain.from_iterable(c.diagnoses for c in columns))
    mistakes: dict[str, list[str]] = {}
    for key, name in compress(zip(keys, diagnoses, strict=True), map(is_not, diagnoses, repeat(None))):
        mistakes.setdefault(key, []).append(name)
    stats = {key: (total, rights[key], blanks[key], mistakes.get(key, ())) for key, total in totals.items()}
    for key, (total, right, unanswered, names) in stats.items():
        common = ", ".join(f"{name} ({n})" for name, n in Counter(names).most_common(3)) or "–"
        share = 100.0 * right / total
        out.append(
            f"| {md_cell(key)} | {share:.0f} % ({right}/{total}) | {total - unanswered} | {md_cell(common)} |"
        )
    out.append("")
    if carried:
        out += _carried_section(submitted, carry_limits)
    out += ["## Integrity flags", ""]
    out += [f"- {md_cell(f.describe())}" for f in flags] or ["None."]
    out += ["", "## Files", "", "| File | Status | Detail |", "|---|---|---|"]
    out += [f"| {md_cell(p)} | {md_cell(s)} | {md_cell(d)} |" for p, s, d in files]
    missing = [g.student for g in grades if g.submission is None]
    out += ["", "## Students without a submission", ""]
    out += [f"- {md_cell(s.student_id)} {md_cell(s.name)}" for s in missing] or ["None."]
    messages = [(g.student.student_id, i) for g in submitted for i in g.issues]
    out += ["", "## Messages", ""]
    out += [f"- {md_cell(sid)}: {md_cell(str(i))}" for sid, i in messages] or ["None."]
    out.append("")
    return first_section("\n".join(out), attention)


def _carried_section(submitted: Sequence[StudentGrade], limits: Sequence[tuple[str, str]] = ()) -> list[str]:
    """How many answers earned carried-forward credit, of how many students, per answer; and the
    later answers that cannot be carried (or only in part), with why."""
    per: Counter[str] = Counter()
    students = 0
    for g in submitted:
        c = g.columns()
        mine = [key for key, carried in zip(c.keys, c.carried, strict=True) if carried]
        per.update(mine)
        students += bool(mine)
    out = ["## Carried forward", ""]
    if not per:
        out += ["No answer was carried forward.", ""]
    else:
        out += [f"{sum(per.values())} answers of {students} students earned credit as consistent with the "
                "student's own earlier (wrong) answers.", "", "| Answer | Carried |", "|---|---|"]
        out += [f"| {md_cell(k)} | {n} |" for k, n in per.items()]
        out.append("")
    if limits:
        out += ["Later answers not carried, or only in part:", "", "| Answer | Why |", "|---|---|"]
        out += [f"| {md_cell(k)} | {md_cell(why)} |" for k, why in limits]
        out.append("")
    return out


def first_section(report: str, section: str) -> str:
    """*report* with *section* as its first ``##`` section (after the summary lines)."""
    cut = report.find("\n## ")
    if not section or cut < 0:
        return report + ("\n" + section if section else "")
    return report[: cut + 1] + section + report[cut + 1 :]
