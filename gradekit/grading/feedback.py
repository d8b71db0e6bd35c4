"""Each student's feedback: one row of plain-text cells per answer, written as Markdown and as an HTML page."""

from __future__ import annotations

import html
import math
from collections.abc import Mapping
from dataclasses import replace
from typing import NamedTuple

from gradekit.grading.compare import AnswerResult, StudentGrade
from gradekit.grading.lms import submitted_name
from gradekit.numbers import fmt as report_fmt
from gradekit.units import pretty, spaced


def fmt(value: float | None, digits: int = 4) -> str:
    """A number for people: `gradekit.numbers.fmt` (the one formatter) at 4 significant figures; None is blank."""
    return "" if value is None else report_fmt(value, digits)


def credit_text(credit: float) -> str:
    """``full credit`` or ``credit 50 %`` (a carried answer's share of its points)."""
    return "full credit" if credit >= 1.0 - 1e-9 else f"credit {100 * credit:.3g} %"


GENERIC_HINT = "check the sign convention, the units and the component asked"
UNNAMED_NOTE = (
    "Likely mistake names only a mistake of method (a static answer to a dynamic problem, the inertia "
    "torque or gravity left out); any other wrong answer reads \"" + GENERIC_HINT + "\", since naming a "
    "slip of sign, unit or component would give your key away."
)
HINTS = ("direction", "band")  # what feedback without --reveal says about a wrong answer

COLUMNS = ("Answer", "You wrote", "Read as", "Verdict", "Off by", "Likely mistake", "Points")
_CSS_CLASS = {"right": "right", "wrong": "wrong", "not graded": "not", "carried forward": "carried",
              "partial credit": "partial", "checked by hand": "not"}


class FeedbackRow(NamedTuple):
    """One answer's feedback row as plain text: its cells in `COLUMNS` order (then the correct
    answer with --reveal) and its verdict (``right``, ``wrong``, ``not graded``, ``carried
    forward``). Markdown and HTML escape the same cells."""

    cells: tuple[str, ...]
    verdict: str


def feedback_row(
    r: AnswerResult, reveal: bool, hint: str = "direction", memo: FeedbackMemo | None = None
) -> FeedbackRow:
    """The feedback row of one answer (see `FeedbackRow`); *memo*: the class's `FeedbackMemo`."""
    memo = FeedbackMemo() if memo is None else memo
    entry, answer = r.entry, r.answer
    unit = memo.unit(entry.unit)
    read = "" if answer is None else answer.written
    if r.value is not None and answer is not None:
        given = memo.unit(answer.unit) if answer.unit else f"{unit} (no unit given)"
        parsed = spaced(fmt(answer.number, 6), given)
        if answer.unit and answer.unit != entry.unit:
            parsed += f" = {spaced(fmt(r.value, 6), unit)}"
    else:
        parsed = r.message
    if entry.hand_check:
        verdict = "checked by hand"
    elif r.correct:
        verdict = "right"
    elif r.value is None:
        verdict = "not graded"
    elif r.carried is not None:
        verdict = "carried forward"
    elif r.partial:
        verdict = "partial credit"
    else:
        verdict = "wrong"
    off = _off(r, unit, reveal, hint) if not r.correct and r.error is not None else ""
    if r.carried is not None:  # the student's own values only: safe without --reveal
        share = r.points / entry.points if entry.points else 1.0
        diagnosis = f"{r.carried.describe()}; carried forward ({credit_text(share)})"
    else:
        diagnosis = _likely(r, reveal, verdict == "wrong")
    cells = (entry.key, read, parsed, verdict, off, diagnosis, memo.points(r.points, entry.points, r.pending))
    if reveal:
        cells += (f"{fmt(entry.value, 6)} {unit} ({entry.tolerance.describe()})",)
    return FeedbackRow(cells, verdict)


def points_text(earned: float, worth: float, pending: bool) -> str:
    """The Points cell: ``2.5/2.5``, ``0/1``, or ``by hand, of 5`` for an answer checked by hand whose
    points are not given yet."""
    shown = fmt(worth)  # an answer's points, and what a right one earned
    if pending:
        return f"by hand, of {shown}"
    return f"{shown if earned == worth else fmt(earned)}/{shown}"


def _likely(r: AnswerResult, reveal: bool, wrong: bool) -> str:
    """The Likely mistake cell: any catalogued mistake with *reveal*; without, a mistake of method
    (`METHOD_MISTAKES`) or, for every other wrong answer alike, `GENERIC_HINT`.

    A sign flip, a unit slip, x and y swapped or the magnitude for a component is a fixed
    transformation of the key: naming it would let the student compute their key from their answer.
    """
    m = r.diagnosis if reveal else r.method_diagnosis
    if m is not None:
        return f"{m.name}: {m.description}"
    return GENERIC_HINT if wrong and not reveal else ""


def _off(r: AnswerResult, unit: str, reveal: bool, hint: str = "direction") -> str:
    """How far off a wrong answer is, without handing a student their key unless *reveal*.

    An angle's difference is in degrees, wrapped at 360° (never a percentage of the angle).
    Without *reveal*: the direction ("too high") and that it is outside the tolerance, and with
    *hint* ``band`` a coarse band in multiples of the tolerance; never a signed amount, which
    would let the student back out the key value.
    """
    if r.error is None or r.abs_error is None or r.correct:
        return ""
    degrees = r.angle and unit in ("rad",)
    amount = r.abs_error * (180.0 / math.pi if degrees else 1.0)
    if not reveal:
        way = (f"too far {'counterclockwise' if r.error > 0 else 'clockwise'}" if r.angle
               else f"too {'high' if r.error > 0 else 'low'}")
        band = r.band if r.band is not None else r.entry.tolerance.band(r.entry.value)
        if hint == "band" and band > 0:
            times = r.abs_error / band
            coarse = ("within twice the tolerance" if times <= 2 else "2 to 10 times the tolerance away"
                      if times <= 10 else "more than 10 times the tolerance away")
            return f"{way}, {coarse}"
        return f"{way}, outside the tolerance" + (" but inside the partial-credit band" if r.partial else "")
    if r.angle:
        return f"{fmt(amount, 3)}° {'counterclockwise' if r.error > 0 else 'clockwise'} (wrapped at 360°)"
    if r.rel_error is not None:
        return f"{'+' if r.error > 0 else '−'}{100 * r.rel_error:.3g} %"
    return f"{'+' if r.error > 0 else '−'}{fmt(r.abs_error)} {unit}"


def md_cell(text: str) -> str:
    """*text* as inline Markdown that shows as written (a table cell, a heading, a list item): each
    character Markdown reads as markup escaped with a backslash, the backslash first, and a line break
    as a space (a table row is one line)."""
    return (text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ").replace("\r", " ")
            .replace("`", "\\`").replace("*", "\\*").replace("_", "\\_").replace("<", "\\<").replace(">", "\\>")
            .replace("[", "\\[").replace("]", "\\]"))


class FeedbackMemo:
    """What the feedback of one class repeats, each made once: a unit as printed, a Points cell, a
    cell text escaped for Markdown and for HTML, and the escaped end of a row (its verdict, Off by,
    Likely mistake and Points). Most cells repeat from student to student (an answer's key, the
    verdicts, the points, the hints): a class of 3,000 has about a quarter as many distinct cells as
    cells. One per class: it keeps every distinct text it was given."""

    def __init__(self) -> None:
        self._md: dict[str, str] = {}
        self._html: dict[str, str] = {}
        self._units: dict[str, str] = {}
        self._points: dict[tuple[float, float, bool], str] = {}
        self._ends: dict[tuple[str, ...], tuple[str, str]] = {}

    def md(self, text: str) -> str:
        """*text* as `md_cell` escapes it."""
        got = self._md.get(text)
        if got is None:
            got = self._md[text] = md_cell(text)
        return got

    def html(self, text: str) -> str:
        """*text* as `html.escape` escapes it."""
        got = self._html.get(text)
        if got is None:
            got = self._html[text] = html.escape(text)
        return got

    def unit(self, unit: str) -> str:
        """*unit* as printed (`gradekit.units.pretty`)."""
        got = self._units.get(unit)
        if got is None:
            got = self._units[unit] = pretty(unit)
        return got

    def points(self, earned: float, worth: float, pending: bool) -> str:
        """`points_text`."""
        got = self._points.get((earned, worth, pending))
        if got is None:
            got = self._points[earned, worth, pending] = points_text(earned, worth, pending)
        return got

    def rows(self, row: FeedbackRow) -> tuple[str, str]:
        """*row* as a Markdown table row and as an HTML table row (its class the verdict's), every cell
        escaped. A cell's escape is its characters' (`md_cell`, `html.escape`), so a row is its cells'
        escapes joined."""
        c = row.cells
        end = self._ends.get(c[3:])
        if end is None:
            end = self._ends[c[3:]] = (" | ".join(map(self.md, c[3:])) + " |",
                                       "</td><td>".join(map(self.html, c[3:])) + "</td></tr>")
        # what the student wrote and how it was read differ from student to student: escaped as they come
        return (f"| {self.md(c[0])} | {md_cell(c[1])} | {md_cell(c[2])} | {end[0]}",
                f'<tr class="{_CSS_CLASS[row.verdict]}"><td>{self.html(c[0])}</td><td>{html.escape(c[1])}</td><td>'
                f'{html.escape(c[2])}</td><td>{end[1]}')


def markdown_row(row: FeedbackRow, memo: FeedbackMemo | None = None) -> str:
    """A feedback row as a Markdown table row (*memo*: the class's `FeedbackMemo`)."""
    return (FeedbackMemo() if memo is None else memo).rows(row)[0]


def html_row(row: FeedbackRow, memo: FeedbackMemo | None = None) -> str:
    """A feedback row as an HTML table row, its class the verdict's (*memo*: the class's `FeedbackMemo`)."""
    return (FeedbackMemo() if memo is None else memo).rows(row)[1]


_CSS = (
    "body{font-family:sans-serif;max-width:60em;margin:2em auto}"
    "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:.2em .5em}"
    ".right{background:#e6f4e6}.wrong{background:#fbe9e9}.not{background:#f3f3f3}.carried,.partial{background:#fdf5dc}"
)


def feedback_pages(
    grade: StudentGrade, titles: Mapping[str, str], assignment_title: str, reveal: bool, hint: str = "direction",
    memo: FeedbackMemo | None = None, file: bool = True,
) -> tuple[str, str]:
    """One student's feedback as (Markdown, standalone HTML page), both from one `feedback_row` per
    answer; every text is escaped (students wrote some of it), through the class's *memo* when the pages
    of a whole class are made. The graded file is named as the student uploaded it, never by its path on
    the instructor's disk; without *file* (answers typed on the online page, not a file of theirs)
    neither it nor the problems of reading it are shown."""
    e = html.escape
    columns = COLUMNS + (("Correct answer",) if reveal else ())
    md_head = "| " + " | ".join(columns) + " |"
    md_rule = "|" + "---|" * len(columns)
    html_head = "<table><tr>" + "".join(f"<th>{e(t)}</th>" for t in columns) + "</tr>"
    s = grade.student
    score = f"Score: {fmt(grade.total)} / {fmt(grade.max_points)} ({grade.percent:.1f} %)"
    title = f"{assignment_title}: feedback for {s.display} ({s.student_id})"
    md = [
        f"# {md_cell(assignment_title)}: feedback for {md_cell(s.display)} ({md_cell(s.student_id)})",
        "",
        f"**{score}**",
        "",
    ]
    page = [
        "<!doctype html>",
        '<html><head><meta charset="utf-8">',
        f"<title>{e(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        f"<p><strong>{score}</strong></p>",
    ]
    if grade.submission is None:
        md += ["No submission was found for you.", ""]
        page.append("<p>No submission was found for you.</p>")
    else:
        if file:
            name = submitted_name(grade.submission.path)
            md += [f"Graded file: {md_cell(name)}", ""]
            page.append(f"<p>Graded file: <code>{e(name)}</code></p>")
        if not reveal:
            md += [md_cell(UNNAMED_NOTE), ""]
            page.append(f"<p>{e(UNNAMED_NOTE)}</p>")
    memo = FeedbackMemo() if memo is None else memo
    rows: dict[str, list[tuple[str, str]]] = {}
    for r in grade.results:
        rows.setdefault(r.entry.problem, []).append(memo.rows(feedback_row(r, reveal, hint, memo)))
    for problem in grade.problems:
        name = titles.get(problem.problem, problem.problem)
        earned = f"{fmt(problem.points)} / {fmt(problem.max_points)}"
        mine = rows.get(problem.problem, [])
        md += [f"## {md_cell(name)}: {earned}", "", md_head, md_rule, *(m for m, _ in mine), ""]
        page += [f"<h2>{e(name)}: {earned}</h2>", html_head, *(h for _, h in mine), "</table>"]
    if grade.issues and file:
        issues = [str(replace(i, path=submitted_name(i.path))) for i in grade.issues]
        md += ["## Problems reading your file", "", *(f"- {md_cell(i)}" for i in issues), ""]
        page += ["<h2>Problems reading your file</h2><ul>", *(f"<li><code>{e(i)}</code></li>" for i in issues), "</ul>"]
    page.append("</body></html>")
    return "\n".join(md), "\n".join(page)


def feedback_markdown(
    grade: StudentGrade, titles: Mapping[str, str], assignment_title: str, reveal: bool, hint: str = "direction"
) -> str:
    """One student's feedback as Markdown (every cell escaped: students wrote some of it)."""
    return feedback_pages(grade, titles, assignment_title, reveal, hint)[0]


def feedback_html(
    grade: StudentGrade, titles: Mapping[str, str], assignment_title: str, reveal: bool, hint: str = "direction"
) -> str:
    """One student's feedback as a standalone HTML page (every text escaped)."""
    return feedback_pages(grade, titles, assignment_title, reveal, hint)[1]
