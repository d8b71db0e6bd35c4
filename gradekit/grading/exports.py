"""Write grades: the grade table, LMS imports, per-student feedback, the report and its plot."""

from __future__ import annotations

import html
import math
import re
import statistics
from collections import Counter
from collections.abc import Mapping, Sequence
from functools import lru_cache
from itertools import chain, compress, repeat
from operator import is_, is_not
from pathlib import Path

from gradekit.csvsafe import atomic_write, write_csv
from gradekit.grading.compare import AnswerResult, StudentGrade
from gradekit.grading.integrity import IntegrityFlag
from gradekit.numbers import fmt as report_fmt
from gradekit.roster import safe_name, safe_names  # noqa: F401 (re-exported: output file names)
from gradekit.units import pretty


def fmt(value: float | None, digits: int = 4) -> str:
    """A number for people: `gradekit.numbers.fmt` (the one formatter) at 4 significant figures; None is blank."""
    return "" if value is None else report_fmt(value, digits)


def points(value: float) -> float | int:
    """Points as written to CSVs: whole numbers as int, otherwise rounded to 4 decimals."""
    rounded = round(value, 4)
    return int(rounded) if rounded == int(rounded) else rounded


def write_grades(
    path: Path, grades: Sequence[StudentGrade], problems: Sequence[str], titles: Mapping[str, str],
    carried: bool = False,
) -> None:
    """``student_id,name``, points per problem, ``total,max,percent``; one row per student. With
    *carried* (grading with carried-forward credit), a last column counts each student's answers
    credited as carried forward."""
    header = ["student_id", "name", *(titles.get(p, p) for p in problems), "total", "max", "percent"]
    if carried:
        header.append("carried")
    rows = []
    for g in grades:
        earned = {p.problem: p.points for p in g.problems}
        row = [
            g.student.student_id,
            one_line(g.student.name),
            *(points(earned.get(p, 0.0)) for p in problems),
            points(g.total),
            points(g.max_points),
            round(g.percent, 2),
        ]
        if carried:
            row.append(sum(g.columns().carried))
        rows.append(row)
    write_csv(path, header, rows)


def credit_text(credit: float) -> str:
    """``full credit`` or ``credit 50 %`` (a carried answer's share of its points)."""
    return "full credit" if credit >= 1.0 - 1e-9 else f"credit {100 * credit:.3g} %"


def write_canvas(path: Path, grades: Sequence[StudentGrade], assignment_title: str) -> None:
    """Canvas gradebook import: ``Student, ID, SIS User ID, SIS Login ID, Section, <title>``.

    Canvas matches a row by ``ID`` (its own user id, from a Canvas roster), else ``SIS User ID``
    (our student id), else ``SIS Login ID``; the grade is the points total.
    """
    header = ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", assignment_title]
    rows = [
        [
            _last_first(g.student.name),
            one_line(g.student.lms_id),
            one_line(g.student.student_id),
            one_line(g.student.sis_login),
            one_line(g.student.section),
            points(g.total),
        ]
        for g in grades
    ]
    write_csv(path, [one_line(h) for h in header], rows)


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+")


def one_line(text: str) -> str:
    """*text* as one line for an LMS cell: newlines, tabs and control characters become one space."""
    return " ".join(_CONTROL.sub(" ", str(text)).split())


def _last_first(name: str) -> str:
    name = one_line(name)
    first, _, last = name.rpartition(" ")
    return f"{last}, {first}" if first else name


def write_moodle(path: Path, grades: Sequence[StudentGrade], assignment_title: str) -> None:
    """Moodle grade import (Grades > Import > CSV file): ``ID number,Email address,<title>``.

    Map ``ID number`` to "ID number" (or ``Email address`` to "Email address") and the title
    column to the grade item in Moodle's import dialog; the grade is the points total.
    """
    header = ["ID number", "Email address", one_line(assignment_title)]
    rows = [[one_line(g.student.student_id), one_line(g.student.email), points(g.total)] for g in grades]
    write_csv(path, header, rows)


class _Memo(dict):
    """A bounded memo of a function of one string: the same units, keys and messages recur in
    every student's feedback (cleared when full, so a hostile class cannot grow it)."""

    def __init__(self, fn, size: int = 4096) -> None:
        super().__init__()
        self.fn = fn
        self.size = size

    def __missing__(self, key: str) -> str:
        if len(self) >= self.size:
            self.clear()
        value = self[key] = self.fn(key)
        return value


_PRETTY = _Memo(pretty)
_POINTS: dict[tuple[float, float], str] = {}


def _points_cell(earned: float, worth: float) -> str:
    text = _POINTS.get((earned, worth))
    if text is None:
        if len(_POINTS) > 4096:
            _POINTS.clear()
        text = _POINTS[(earned, worth)] = f"{fmt(earned)}/{fmt(worth)}"
    return text


_PLAIN_DECIMAL = re.compile(r"-?(?:0|[1-9][0-9]{0,14})(?:\.[0-9]*[1-9])?")  # no exponent, no needless zero


def _as_read(raw: str, number: float) -> str:
    """``fmt(number, 6)`` for a number a student wrote as *raw*.

    A plain decimal of 1 to 6 significant figures below 10¹⁵ (``40.77``, ``-0.00123``) is already
    what the formatter prints for it, so most cells skip the formatter.
    """
    if _PLAIN_DECIMAL.fullmatch(raw) and 0 < len(raw.lstrip("-").replace(".", "").strip("0")) <= 6:
        return raw
    return fmt(number, 6)


def _answer_cells(r: AnswerResult, reveal: bool, hint: str) -> tuple[str, ...]:
    """The cells of one feedback row as plain text, in `_COLUMNS` order (then the correct answer
    with *reveal*); the Markdown and the HTML page escape the same cells."""
    entry, answer = r.entry, r.answer
    unit = _PRETTY[entry.unit]
    read = ""
    if answer is not None:
        read = answer.raw + (f" [{answer.raw_unit}]" if answer.raw_unit else "")
    if r.value is not None and answer is not None:
        given = _PRETTY[answer.unit] if answer.unit else f"{unit} (no unit given)"
        parsed = f"{_as_read(answer.raw, answer.number)} {given}".strip()
        if answer.unit and answer.unit != entry.unit:
            parsed += f" = {fmt(r.value, 6)} {unit}"
    else:
        parsed = r.message
    if r.correct:
        verdict = "right"
    elif r.value is None:
        verdict = "not graded"
    elif r.carried is not None:
        verdict = "carried forward"
    else:
        verdict = "wrong"
    off = _off(r, unit, reveal, hint) if not r.correct and r.error is not None else ""
    if r.carried is not None:  # the student's own values only: safe without --reveal
        share = r.points / entry.points if entry.points else 1.0
        diagnosis = f"{r.carried.describe()}; carried forward ({credit_text(share)})"
    else:
        diagnosis = _likely(r, reveal, verdict == "wrong")
    points = _points_cell(r.points, entry.points)
    if reveal:
        correct = f"{fmt(entry.value, 6)} {unit} ({entry.tolerance.describe()})"
        return entry.key, read, parsed, verdict, off, diagnosis, points, correct
    return entry.key, read, parsed, verdict, off, diagnosis, points


GENERIC_HINT = "check the sign convention, the units and the component asked"
UNNAMED_NOTE = (
    "Likely mistake names only a mistake of method (a static answer to a dynamic problem, the inertia "
    "torque or gravity left out); any other wrong answer reads \"" + GENERIC_HINT + "\", since naming a "
    "slip of sign, unit or component would give your key away."
)


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


HINTS = ("direction", "band")  # what feedback without --reveal says about a wrong answer


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
        band = r.entry.tolerance.band(r.entry.value)
        if hint == "band" and band > 0:
            times = r.abs_error / band
            coarse = ("within twice the tolerance" if times <= 2 else "2 to 10 times the tolerance away"
                      if times <= 10 else "more than 10 times the tolerance away")
            return f"{way}, {coarse}"
        return f"{way}, outside the tolerance"
    if r.angle:
        return f"{fmt(amount, 3)}° {'counterclockwise' if r.error > 0 else 'clockwise'} (wrapped at 360°)"
    if r.rel_error is not None:
        return f"{'+' if r.error > 0 else '−'}{100 * r.rel_error:.3g} %"
    return f"{'+' if r.error > 0 else '−'}{fmt(r.abs_error)} {unit}"


_COLUMNS = [
    ("key", "Answer"),
    ("read", "You wrote"),
    ("parsed", "Read as"),
    ("verdict", "Verdict"),
    ("off", "Off by"),
    ("diagnosis", "Likely mistake"),
    ("points", "Points"),
]


_MD_SPECIAL = re.compile(r"[`*_<>\[\]\\|\n\r]")
_MD_ESCAPE = re.compile(r"([`*_<>\[\]])")
_SPECIAL = re.compile(r"[`*_<>\[\]\\|\n\r&\"']")  # a character Markdown or HTML escapes


def _md_cell(text: str) -> str:
    if not _MD_SPECIAL.search(text):  # most cells: nothing to escape
        return text
    text = text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ").replace("\r", " ")
    return _MD_ESCAPE.sub(r"\\\1", text)


_MD = _Memo(_md_cell)
_HTML = _Memo(html.escape)
_CSS_CLASS = {"right": "right", "wrong": "wrong", "not graded": "not", "carried forward": "carried"}


def _rows(r: AnswerResult, reveal: bool, hint: str) -> tuple[str, str]:
    """One answer's feedback row as (Markdown table row, HTML table row), every cell escaped."""
    answer = r.answer
    if r.correct and not reveal and r.carried is None and r.method_diagnosis is None and answer is not None:
        return _right_rows(r, answer)
    return _any_rows(r, reveal, hint)


def _any_rows(r: AnswerResult, reveal: bool, hint: str) -> tuple[str, str]:
    """`_rows` of any answer, from `_answer_cells` (the fast path `_right_rows` must equal it)."""
    answer = r.answer
    cells = _answer_cells(r, reveal, hint)
    key, rest = cells[0], cells[2:]
    md_read, html_read = _read_cells(answer.raw, answer.raw_unit) if answer is not None else ("", "")
    if not _SPECIAL.search("".join(rest)):  # most rows: numbers, units and fixed phrases
        md_rest = html_rest = rest
    else:
        md_rest = tuple(_MD[c] for c in rest)
        html_rest = tuple(_HTML[c] for c in rest)
    md = f"| {_MD[key]} | {md_read} | " + " | ".join(md_rest) + " |"
    page = (f'<tr class="{_CSS_CLASS[cells[3]]}"><td>{_HTML[key]}</td><td>{html_read}</td><td>'
            + "</td><td>".join(html_rest) + "</td></tr>")
    return md, page


def _read_cells(raw: str, raw_unit: str) -> tuple[str, str]:
    """The You wrote cell (``raw``, or ``raw [raw_unit]``) escaped for Markdown and for HTML.

    Both escapes act character by character, so the cell is escaped in parts: the value a student
    wrote (nearly always plain) and the bracketed unit (recurring: memoised).
    """
    if raw_unit:
        md_raw, html_raw = (raw, raw) if not _SPECIAL.search(raw) else (_md_cell(raw), html.escape(raw))
        return f"{md_raw} \\[{_MD[raw_unit]}\\]", f"{html_raw} [{_HTML[raw_unit]}]"
    if not _SPECIAL.search(raw):
        return raw, raw
    return _md_cell(raw), html.escape(raw)


def _right_rows(r: AnswerResult, answer) -> tuple[str, str]:
    """`_rows` of a right answer without *reveal* (most rows): its cells are those `_answer_cells`
    makes (nothing is off, no mistake is named), written straight into both rows.

    What a row holds besides the student's value (`_right_parts`) is the same for every row of one
    answer key written in one unit for the same points: made once. Both escapes act character by
    character, so the parts are escaped apart; the value as read (`_as_read`: a plain decimal or the
    formatter's digits) and a converted value (the formatter's) have nothing to escape.
    """
    entry = r.entry
    raw = answer.raw
    parts = _RIGHT.get((entry.key, entry.unit, answer.unit, answer.raw_unit, r.points, entry.points))
    if parts is None:
        parts = _right_parts(entry.key, entry.unit, answer.unit, answer.raw_unit, r.points, entry.points)
    md_key, md_raw_unit, md_given, html_key, html_raw_unit, html_given, md_end, html_end, converted = parts
    md_raw, html_raw = (raw, raw) if not _SPECIAL.search(raw) else (_md_cell(raw), html.escape(raw))
    read = _as_read(raw, answer.number)
    if converted is not None:  # "<read> <given unit> = <value> <key's unit>"
        value = f" = {fmt(r.value, 6)}"
        md_end, html_end = value + converted[0] + md_end, value + converted[1] + html_end
    return (md_key + md_raw + md_raw_unit + read + md_given + md_end,
            html_key + html_raw + html_raw_unit + read + html_given + html_end)


_RIGHT: dict[tuple, tuple] = {}


def _right_parts(key: str, key_unit: str, given_unit: str, raw_unit: str, earned: float, worth: float) -> tuple:
    """The parts of a right answer's rows around its values (see `_right_rows`), kept in `_RIGHT`: in
    Markdown then HTML, the row up to the value written, the bracketed unit written, the Read as
    cell's unit after the value read; the row's end from the Read as cell's end; and for an answer
    converted into the key's unit, that unit (Markdown, HTML) after the converted value, else None."""
    unit = _PRETTY[key_unit]
    given = _PRETTY[given_unit] if given_unit else f"{unit} (no unit given)"
    given = (" " + given).rstrip()  # as `f"{read} {given}".strip()`: the value read is never blank
    points = _points_cell(earned, worth)
    md_raw_unit, html_raw_unit = (f" \\[{_MD[raw_unit]}\\]", f" [{_HTML[raw_unit]}]") if raw_unit else ("", "")
    converted = (_MD[f" {unit}"], _HTML[f" {unit}"]) if given_unit and given_unit != key_unit else None
    parts = (
        f"| {_MD[key]} | ", md_raw_unit + " | ", _MD[given],
        f'<tr class="right"><td>{_HTML[key]}</td><td>', html_raw_unit + "</td><td>", _HTML[given],
        f" | right |  |  | {_MD[points]} |", f"</td><td>right</td><td></td><td></td><td>{_HTML[points]}</td></tr>",
        converted,
    )
    if len(_RIGHT) > 4096:
        _RIGHT.clear()
    _RIGHT[(key, key_unit, given_unit, raw_unit, earned, worth)] = parts
    return parts


_CSS = (
    "body{font-family:sans-serif;max-width:60em;margin:2em auto}"
    "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:.2em .5em}"
    ".right{background:#e6f4e6}.wrong{background:#fbe9e9}.not{background:#f3f3f3}.carried{background:#fdf5dc}"
)


@lru_cache(maxsize=2)
def _heads(reveal: bool) -> tuple[str, str, str]:
    """A feedback table's head: (Markdown header row, its rule, HTML table start and header row)."""
    columns = _COLUMNS + ([("correct", "Correct answer")] if reveal else [])
    return (
        "| " + " | ".join(t for _, t in columns) + " |",
        "|" + "---|" * len(columns),
        "<table><tr>" + "".join(f"<th>{html.escape(t)}</th>" for _, t in columns) + "</tr>",
    )


def feedback_pages(
    grade: StudentGrade, titles: Mapping[str, str], assignment_title: str, reveal: bool, hint: str = "direction"
) -> tuple[str, str]:
    """One student's feedback as (Markdown, standalone HTML page), both from one pass over the
    answers; every text is escaped (students wrote some of it)."""
    e = html.escape
    md_head, md_rule, html_head = _heads(reveal)
    s = grade.student
    score = f"Score: {fmt(grade.total)} / {fmt(grade.max_points)} ({grade.percent:.1f} %)"
    title = f"{assignment_title}: feedback for {s.display} ({s.student_id})"
    md = [
        f"# {_md_cell(assignment_title)}: feedback for {_md_cell(s.display)} ({_md_cell(s.student_id)})",
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
        md += [f"Graded file: {_md_cell(grade.submission.path)}", ""]
        page.append(f"<p>Graded file: <code>{e(grade.submission.path)}</code></p>")
        if not reveal:
            md += [_MD[UNNAMED_NOTE], ""]
            page.append(f"<p>{_HTML[UNNAMED_NOTE]}</p>")
    rows: dict[str, list[tuple[str, str]]] = {}
    for r in grade.results:
        rows.setdefault(r.entry.problem, []).append(_rows(r, reveal, hint))
    for problem in grade.problems:
        name = titles.get(problem.problem, problem.problem)
        earned = f"{fmt(problem.points)} / {fmt(problem.max_points)}"
        mine = rows.get(problem.problem, [])
        md += [f"## {_MD[name]}: {earned}", "", md_head, md_rule, *(m for m, _ in mine), ""]
        page += [f"<h2>{_HTML[name]}: {earned}</h2>", html_head, *(h for _, h in mine), "</table>"]
    if grade.issues:
        issues = [str(i) for i in grade.issues]
        md += ["## Problems reading your file", "", *(f"- {_md_cell(i)}" for i in issues), ""]
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
    ax.set_title(title)
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
) -> str:
    """The instructor's report: summary, item analysis, (answers carried forward,) integrity flags,
    file accounting."""
    submitted = [g for g in grades if g.submission is not None]
    percents = [g.percent for g in submitted]
    out = [f"# {_md_cell(assignment_title)}: grading report", ""]
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
            f"| {_md_cell(key)} | {share:.0f} % ({right}/{total}) | {total - unanswered} | {_md_cell(common)} |"
        )
    out.append("")
    if carried:
        out += _carried_section(submitted, carry_limits)
    out += ["## Integrity flags", ""]
    out += [f"- {_md_cell(f.describe())}" for f in flags] or ["None."]
    out += ["", "## Files", "", "| File | Status | Detail |", "|---|---|---|"]
    out += [f"| {_md_cell(p)} | {_md_cell(s)} | {_md_cell(d)} |" for p, s, d in files]
    missing = [g.student for g in grades if g.submission is None]
    out += ["", "## Students without a submission", ""]
    out += [f"- {_md_cell(s.student_id)} {_md_cell(s.name)}" for s in missing] or ["None."]
    messages = [(g.student.student_id, i) for g in submitted for i in g.issues]
    out += ["", "## Messages", ""]
    out += [f"- {_md_cell(sid)}: {_md_cell(str(i))}" for sid, i in messages] or ["None."]
    out.append("")
    return "\n".join(out)


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
        out += [f"| {_md_cell(k)} | {n} |" for k, n in per.items()]
        out.append("")
    if limits:
        out += ["Later answers not carried, or only in part:", "", "| Answer | Why |", "|---|---|"]
        out += [f"| {_md_cell(k)} | {_md_cell(why)} |" for k, why in limits]
        out.append("")
    return out


def write_text(path: Path, text: str) -> None:
    """Write a text output atomically."""
    atomic_write(path, text)
