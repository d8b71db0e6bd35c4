"""What grading writes, as a table of exports the assignment or the command line chooses from.

Each export is one row of `EXPORTS` (its name, the files it writes, what it is for, its writer);
`write_exports` writes the chosen ones from one `GradedClass`. The formats live in their own
modules: `gradekit.grading.lms` (Canvas, Moodle), `gradekit.grading.feedback`,
`gradekit.grading.report`.
"""

from __future__ import annotations

import difflib
import logging
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from gradekit.csvsafe import atomic_write, write_csv, write_staged
from gradekit.errors import GradekitError
from gradekit.grading.compare import StudentGrade
from gradekit.grading.feedback import FeedbackMemo, feedback_pages
from gradekit.grading.hand import FILE as HAND_FILE
from gradekit.grading.hand import write_hand
from gradekit.grading.integrity import IntegrityFlag
from gradekit.grading.lms import (  # noqa: F401 (re-exported)
    canvas_feedback_name,
    moodle_feedback_member,
    one_line,
    points,
    write_canvas,
    write_feedback_zip,
    write_moodle,
)
from gradekit.grading.report import report_markdown, write_histogram
from gradekit.roster import safe_names

log = logging.getLogger(__name__)


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


def write_text(path: Path, text: str) -> None:
    """Write a text output atomically."""
    atomic_write(path, text)


@dataclass(frozen=True)
class GradedClass:
    """What every export reads: the graded class and how it was graded.

    ``grades`` one per roster student in roster order; ``problems`` the item labels in order with
    their ``titles``; ``files`` (path, status, detail) of every file of the submissions folder and
    ``flags`` the integrity flags (both for the report); ``attention`` the report's "Check first"
    section (Markdown, may be empty); ``carried``/``carry_limits`` as graded with carried-forward
    credit; ``canvas_assignment_id`` the Canvas assignment the grades go to (see
    `gradekit.roster.canvas_assignment_id`), empty when unknown; ``hand_notes`` by student and key,
    points given by hand to an earlier answer (`gradekit.grading.hand.still_given`).
    """

    grades: Sequence[StudentGrade]
    problems: Sequence[str]
    titles: Mapping[str, str]
    assignment_title: str
    reveal: bool = False
    hint: str = "direction"
    carried: bool = False
    carry_limits: Sequence[tuple[str, str]] = ()
    files: Sequence[tuple[str, str, str]] = ()
    flags: Sequence[IntegrityFlag] = ()
    attention: str = ""
    canvas_assignment_id: str = ""
    hand_notes: Mapping[tuple[str, str], str] | None = None


class _Pages:
    """Each student's feedback (Markdown, HTML), made once for every export of one `write_exports`
    call that shows it."""

    def __init__(self, graded: GradedClass) -> None:
        self.graded = graded
        self.made: dict[int, tuple[str, str]] = {}
        self.memo = FeedbackMemo()

    def __call__(self, i: int) -> tuple[str, str]:
        if i not in self.made:
            g = self.graded
            self.made[i] = feedback_pages(g.grades[i], g.titles, g.assignment_title, g.reveal, g.hint, self.memo)
        return self.made[i]


@dataclass(frozen=True)
class Export:
    """One thing grading can write: its ``name`` (as chosen), the ``files`` it writes under OUT,
    what it is ``for``, and its ``write`` (OUT, the class, chosen names, pages) -> paths written."""

    name: str
    files: str
    purpose: str
    write: Callable[[Path, GradedClass, Sequence[str], _Pages], list[Path]]


def _grades(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    write_grades(root / "grades.csv", g.grades, g.problems, g.titles, carried=g.carried)
    return [root / "grades.csv"]


def _canvas(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    write_canvas(root / "canvas.csv", g.grades, g.assignment_title, g.canvas_assignment_id)
    return [root / "canvas.csv"]


def _moodle(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    write_moodle(root / "moodle.csv", g.grades, g.assignment_title)
    return [root / "moodle.csv"]


def _feedback(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    folder = root / "feedback"
    folder.mkdir(exist_ok=True)
    names = safe_names(x.student.student_id for x in g.grades)
    prefix = os.path.join(folder, "")
    written = []
    for i, grade in enumerate(g.grades):
        md, page = pages(i)
        stem = prefix + names[grade.student.student_id]
        write_staged(stem + ".md", md)  # a staging folder's file: seen only when the run commits
        write_staged(stem + ".html", page)
        written += [Path(stem + ".md"), Path(stem + ".html")]
    return written


def _hand(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    return [root / HAND_FILE] if write_hand(root / HAND_FILE, g.grades, g.hand_notes) else []


def _report(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    text = report_markdown(
        assignment_title=g.assignment_title, grades=g.grades, files=g.files, flags=g.flags,
        histogram="histogram.svg" if "histogram" in chosen else None, carried=g.carried,
        carry_limits=g.carry_limits, attention=g.attention,
    )
    write_text(root / "report.md", text)
    return [root / "report.md"]


def _histogram(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
    write_histogram(root / "histogram.svg", [x.percent for x in g.grades if x.submission is not None],
                    g.assignment_title)
    return [root / "histogram.svg"]


def _zip(file: str, lms: str, member: Callable[[StudentGrade], str | None]):
    def write(root: Path, g: GradedClass, chosen: Sequence[str], pages: _Pages) -> list[Path]:
        index = {id(x): i for i, x in enumerate(g.grades)}
        left = write_feedback_zip(root / file, g.grades, lambda x: pages(index[id(x)])[1], member)
        if left:
            log.warning("%s: the feedback of %d student(s) is not in it (no %s download name, or no submission): "
                        "%s", file, len(left), lms, ", ".join(left[:5]) + (" …" if len(left) > 5 else ""))
        return [root / file]

    return write


EXPORTS: dict[str, Export] = {
    e.name: e
    for e in (
        Export("grades", "grades.csv", "points per problem, total and percent per student", _grades),
        Export("canvas", "canvas.csv", "Canvas gradebook import (Grades > Import)", _canvas),
        Export("moodle", "moodle.csv", "Moodle grade import (Grades > Import > CSV file)", _moodle),
        Export("feedback", "feedback/<id>.md, .html", "each student's feedback", _feedback),
        Export("report", "report.md", "the instructor's report", _report),
        Export("hand", "hand.csv", "the answers to check by hand, a points column to fill and read back by the "
               "next run (written when there are any)", _hand),
        Export("histogram", "histogram.svg", "the score histogram (the report shows it)", _histogram),
        Export("moodle-feedback-zip", "moodle-feedback.zip",
               "feedback for Moodle's \"Upload multiple feedback files in a zip\"",
               _zip("moodle-feedback.zip", "Moodle", moodle_feedback_member)),
        Export("canvas-feedback-zip", "canvas-feedback.zip",
               "feedback for Canvas's \"Re-upload submissions\" (a submission comment each)",
               _zip("canvas-feedback.zip", "Canvas", canvas_feedback_name)),
    )
}
DEFAULT_EXPORTS = ("grades", "canvas", "moodle", "feedback", "report", "hand", "histogram")


def choose_exports(names: Iterable[str] | None, where: str | None = None, field: str = "exports") -> tuple[str, ...]:
    """The exports *names* chooses, in `EXPORTS` order (`DEFAULT_EXPORTS` for None).

    Raises:
        GradekitError: a name that is no export (the message names *where* and *field*).
    """
    if names is None:
        return DEFAULT_EXPORTS
    names = [str(n).strip() for n in names]
    for n in names:
        if n not in EXPORTS:
            near = difflib.get_close_matches(n, list(EXPORTS), n=1, cutoff=0.6)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise GradekitError(f"expected exports among {', '.join(EXPORTS)}; got {n!r}{hint}", path=where,
                                field=field)
    return tuple(n for n in EXPORTS if n in names)


def write_exports(root: Path, graded: GradedClass, chosen: Sequence[str] = DEFAULT_EXPORTS) -> list[Path]:
    """Write the *chosen* exports of *graded* into *root* (a `gradekit.csvsafe.StagedFolder`'s staging
    folder: feedback files are written in place) and return the paths written. Each student's
    feedback is built once for every export that shows it."""
    root = Path(root)
    pages = _Pages(graded)
    written: list[Path] = []
    for name in choose_exports(chosen):
        written += EXPORTS[name].write(root, graded, tuple(chosen), pages)
    return written
