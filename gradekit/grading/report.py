"""The instructor's grading report (report.md) and its score histogram."""

from __future__ import annotations

import html
import statistics
from collections import Counter
from collections.abc import Sequence
from itertools import chain, compress, repeat
from operator import is_, is_not
from pathlib import Path

from gradekit.csvsafe import atomic_write
from gradekit.grading.compare import StudentGrade
from gradekit.grading.feedback import md_cell
from gradekit.grading.integrity import IntegrityFlag

BINS = 10  # 10 % each; the last bin's upper edge is closed (100 % counts in 90–100 %)


def histogram_counts(percents: Sequence[float]) -> list[int]:
    """Students per 10 % bin of score, 0–10 % … 90–100 %; a perfect score (100.00000000000001 % after
    round-off too) in the last bin."""
    counts = [0] * BINS
    for p in percents:
        counts[min(BINS - 1, max(0, int(min(max(p, 0.0), 100.0) // (100 / BINS))))] += 1
    return counts


def write_histogram(path: Path, percents: Sequence[float], title: str) -> None:
    """A bar chart of the scores in 10 % bins, written as SVG: text as text (the title as the instructor
    wrote it, escaped), each bar with its count as a tooltip, and a text alternative. No plotting library:
    importing matplotlib alone would take longer than grading a class of 300."""
    counts = histogram_counts(percents)
    step = _nice_step(max(counts) / 5)
    top = step * max(1, -(-max(counts) // step))
    left, bottom, width, height = 48.0, 252.0, 400.0, 200.0  # the plot area, in points (y down)
    x_at = [left + width * i / BINS for i in range(BINS + 1)]

    def y_at(n: float) -> float:
        return bottom - height * n / top

    words = ", ".join(f"{10 * i}–{10 * i + 10} %: {n}" for i, n in enumerate(counts))
    shown = html.escape(title, quote=False)  # text content: &, < and > escaped
    out = [
        '<svg xmlns="http://www.w3.org/2000/svg" width="480pt" height="300pt" viewBox="0 0 480 300" '
        'role="img" aria-labelledby="t d" font-family="DejaVu Sans, sans-serif" font-size="10">',
        f'<title id="t">Score histogram: {shown}</title>',
        f'<desc id="d">Students per score range ({sum(counts)} graded): {words}.</desc>',
        '<rect width="480" height="300" fill="white"/>',
        f'<text x="{left + width / 2:g}" y="28" text-anchor="middle" font-size="12">{shown}</text>',
    ]
    for k in range(0, top + 1, step):  # the count axis: gridlines and numbers
        y = y_at(k)
        out.append(f'<line x1="{left:g}" y1="{y:g}" x2="{left + width:g}" y2="{y:g}" stroke="#dddddd"/>')
        out.append(f'<text x="{left - 6:g}" y="{y + 3.5:g}" text-anchor="end">{k}</text>')
    for i, n in enumerate(counts):
        x0, x1 = x_at[i], x_at[i + 1]
        out.append(f'<rect class="bar" x="{x0:g}" y="{y_at(n):g}" width="{x1 - x0:g}" height="{bottom - y_at(n):g}" '
                   f'fill="#0072B2" stroke="black" data-count="{n}">'
                   f'<title>{10 * i}–{10 * i + 10} %: {n}</title></rect>')
    for i, x in enumerate(x_at):
        out.append(f'<text x="{x:g}" y="{bottom + 14:g}" text-anchor="middle">{10 * i}</text>')
    out += [
        f'<line x1="{left:g}" y1="{bottom:g}" x2="{left + width:g}" y2="{bottom:g}" stroke="black"/>',
        f'<line x1="{left:g}" y1="{bottom:g}" x2="{left:g}" y2="{bottom - height:g}" stroke="black"/>',
        f'<text x="{left + width / 2:g}" y="{bottom + 34:g}" text-anchor="middle">score (%)</text>',
        f'<text x="14" y="{bottom - height / 2:g}" text-anchor="middle" '
        f'transform="rotate(-90 14 {bottom - height / 2:g})">students</text>',
        "</svg>",
    ]
    atomic_write(path, "\n".join(out) + "\n")


def _nice_step(raw: float) -> int:
    """The smallest of 1, 2, 5, 10, 20, 50 … at least *raw* (the count axis's step)."""
    magnitude = 1
    while True:
        for m in (1, 2, 5):
            if m * magnitude >= raw:
                return m * magnitude
        magnitude *= 10


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
    by_hand = Counter(r.entry.key for g in submitted for r in g.results if r.entry.hand_check)
    waiting = Counter(r.entry.key for g in submitted for r in g.results if r.pending)
    for key, (total, right, unanswered, names) in stats.items():
        common = ", ".join(f"{name} ({n})" for name, n in Counter(names).most_common(3)) or "–"
        share = 100.0 * right / total
        verdicts = (f"by hand: points given {by_hand[key] - waiting[key]} of {by_hand[key]}" if key in by_hand
                    else f"{share:.0f} % ({right}/{total})")  # never judged by a band: no share right
        out.append(f"| {md_cell(key)} | {verdicts} | {total - unanswered} | {md_cell(common)} |")
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
