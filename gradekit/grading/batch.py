"""Grade a folder of submissions against the keys and write every output: one call for the CLI."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from gradekit.errors import GradekitError
from gradekit.grading.compare import StudentGrade, grade_student
from gradekit.grading.exports import (
    feedback_html,
    feedback_markdown,
    report_markdown,
    safe_names,
    write_canvas,
    write_grades,
    write_histogram,
    write_moodle,
    write_text,
)
from gradekit.grading.integrity import IntegrityFlag, find_copies
from gradekit.grading.reader import IdIndex, KeyIndex, Submission, read_file
from gradekit.keys import KeyEntry
from gradekit.roster import Student

MARKER = ".gradekit-output"


@dataclass(frozen=True)
class FileRecord:
    """What became of one file of the submissions folder.

    ``status`` is one of ``graded``, ``unreadable``, ``unknown student``, ``duplicate`` (another
    file of the same student was graded) or ``ignored`` (hidden and system files).
    """

    path: str
    status: str
    detail: str = ""
    student_ids: tuple[str, ...] = ()


@dataclass(frozen=True)
class Intake:
    """The submissions read from a folder: the one chosen per student, and every file's fate."""

    chosen: dict[str, Submission]
    files: tuple[FileRecord, ...]


@dataclass(frozen=True)
class BatchResult:
    """The outcome of `grade_batch`.

    ``grades`` holds one entry per roster student, in roster order (a student without a
    submission scores 0 with ``submission=None``).
    """

    grades: tuple[StudentGrade, ...]
    files: tuple[FileRecord, ...]
    flags: tuple[IntegrityFlag, ...]
    out: Path
    written: tuple[Path, ...]

    @property
    def graded(self) -> int:
        """How many students had a submission graded."""
        return sum(g.submission is not None for g in self.grades)

    @property
    def missing(self) -> tuple[Student, ...]:
        """Roster students without a submission."""
        return tuple(g.student for g in self.grades if g.submission is None)

    @property
    def ok(self) -> bool:
        """At least one submission could be tied to a student and graded (else: exit 1)."""
        return self.graded > 0

    @property
    def clean(self) -> bool:
        """Every file was read without a message and matched a student; nobody is missing."""
        return (
            all(f.status in ("graded", "ignored") for f in self.files)
            and not self.missing
            and not any(g.issues for g in self.grades)
        )


def _hidden(name: str) -> bool:
    return name.startswith((".", "~$")) or name in ("__MACOSX", "Thumbs.db", "desktop.ini")


def read_submissions(
    submissions: Path, students: Sequence[Student], keys: Sequence[KeyEntry], *, skip: Path | None = None
) -> Intake:
    """Read every file below *submissions* and choose one submission per student.

    Several files for one student: a readable one wins over an unreadable one, then the most
    recently modified, then the last by path; the others are recorded as duplicates.

    Args:
        submissions: the folder (read only; searched recursively, symlinked folders not followed).
        students: the roster.
        keys: every student's key entries (their key names are the ones a file may answer).
        skip: a folder inside *submissions* not to read (the output folder).

    Returns:
        The chosen submission per student id and one record per file.

    Raises:
        GradekitError: *submissions* is not a readable folder.
    """
    if not submissions.is_dir():
        raise GradekitError("expected a folder of submission CSVs, got none there", path=str(submissions))
    ids = IdIndex(students)
    key_index = KeyIndex(e.key for e in keys)
    skip_real = os.path.realpath(skip) if skip is not None else None
    per_file: list[tuple[str, list[Submission]]] = []
    ignored: list[FileRecord] = []
    for root, dirs, names in os.walk(submissions):
        dirs.sort()
        for d in list(dirs):
            full = os.path.join(root, d)
            if _hidden(d) or (skip_real and os.path.realpath(full) == skip_real):
                dirs.remove(d)
                ignored.append(FileRecord(os.path.join(root, d) + os.sep, "ignored", "folder not read"))
        for name in sorted(names):
            path = Path(root) / name
            display = str(path)
            if _hidden(name):
                ignored.append(FileRecord(display, "ignored", "hidden or system file"))
                continue
            relative = os.path.relpath(path, submissions)
            per_file.append((display, read_file(path, display, relative, ids, key_index)))
    if not per_file and not ignored:
        raise GradekitError(
            "expected submission files in this folder, got an empty folder", path=str(submissions)
        )
    by_student: dict[str, list[Submission]] = {}
    for _, subs in per_file:
        for sub in subs:
            if sub.student_id is not None:
                by_student.setdefault(sub.student_id, []).append(sub)
    chosen = {sid: max(subs, key=lambda s: (s.readable, s.mtime, s.path)) for sid, subs in by_student.items()}
    records = [_record(display, subs, chosen) for display, subs in per_file]
    return Intake(chosen, tuple(records + ignored))


def _record(display: str, subs: list[Submission], chosen: dict[str, Submission]) -> FileRecord:
    graded = [s.student_id for s in subs if s.student_id and chosen[s.student_id] is s and s.readable]
    dupes = [s.student_id for s in subs if s.student_id and chosen[s.student_id] is not s]
    unknown = sorted({c for s in subs if s.student_id is None for c in s.claimed})
    unreadable = [s for s in subs if not s.readable]
    parts = []
    if len(subs) > 1 or (subs and subs[0].class_wide):
        parts.append(f"class-wide: {len(graded)} students graded")
    if dupes:
        parts.append(
            "; ".join(f"{sid}: graded {chosen[sid].path} instead" for sid in dupes[:5] if sid)
            + (f" (+{len(dupes) - 5} more)" if len(dupes) > 5 else "")
        )
    if unknown or any(s.student_id is None and s.readable for s in subs):
        parts.append(
            "unknown student " + (", ".join(map(repr, unknown[:5])) or "(no roster id in file or name)")
        )
    if unreadable:
        parts.append(str(unreadable[0].issues[0]) if unreadable[0].issues else "unreadable")
        zero = [s.student_id for s in unreadable if s.student_id and chosen[s.student_id] is s]
        if zero:
            parts.append(f"student {zero[0]} scores 0 for it")
    if graded:
        status = "graded"
        if len(subs) == 1:
            parts.insert(0, f"student {graded[0]}")
    elif unreadable:
        status = "unreadable"
    elif dupes:
        status = "duplicate"
    else:
        status = "unknown student"
    return FileRecord(display, status, "; ".join(p for p in parts if p), tuple(s for s in graded if s))


def grade_students(
    keys: Sequence[KeyEntry], students: Sequence[Student], chosen: Mapping[str, Submission]
) -> list[StudentGrade]:
    """Grade every roster student (in roster order) against their own key entries."""
    entries: dict[str, list[KeyEntry]] = {}
    for entry in keys:
        entries.setdefault(entry.student_id, []).append(entry)
    return [grade_student(s, entries.get(s.student_id, []), chosen.get(s.student_id)) for s in students]


def _prepare_out(out: Path, submissions: Path) -> None:
    """Create OUT, refusing a folder of someone else's files or the submissions folder itself."""
    if out.resolve() == submissions.resolve():
        raise GradekitError("expected an output folder other than the submissions folder", path=str(out))
    if out.exists() and not out.is_dir():
        raise GradekitError("expected an output folder, got a file", path=str(out))
    if out.is_dir() and not (out / MARKER).exists() and any(out.iterdir()):
        raise GradekitError(
            "expected an empty output folder or one gradekit wrote before, got a folder of other files "
            "(choose another --out)",
            path=str(out),
        )
    (out / "feedback").mkdir(parents=True, exist_ok=True)
    write_text(out / MARKER, "gradekit grading output; files here are rewritten by the next run\n")


def grade_batch(
    keys: Sequence[KeyEntry],
    students: Sequence[Student],
    submissions: Path,
    out: Path,
    *,
    assignment_title: str = "Assignment",
    reveal: bool = False,
    problem_titles: Mapping[str, str] | None = None,
    histogram: bool = True,
) -> BatchResult:
    """Grade every submission in a folder and write grades, LMS imports, feedback and a report.

    Writes ``OUT/grades.csv``, ``OUT/canvas.csv``, ``OUT/moodle.csv``,
    ``OUT/feedback/<safe id>.md`` and ``.html`` per roster student, ``OUT/report.md`` and
    ``OUT/histogram.png``; each file atomically. The submissions folder is only read. A bad
    submission never raises: it scores what can be read and its messages go to the feedback and
    the report.

    Args:
        keys: every student's key entries (grouped by ``student_id`` and ``problem``).
        students: the roster.
        submissions: the folder of submission files.
        out: the output folder (created; must be empty or a previous gradekit output).
        assignment_title: the assignment's name (the LMS grade column and the headings).
        reveal: show the correct values in the feedback.
        problem_titles: display names per ``KeyEntry.problem`` (defaults to the problem id).
        histogram: draw ``histogram.png`` (matplotlib).

    Returns:
        The grades, every file's fate, the integrity flags and the files written.

    Raises:
        GradekitError: no keys or students, the submissions folder is missing or empty, or the
            output folder cannot be used.
    """
    submissions, out = Path(submissions), Path(out)
    if not keys:
        raise GradekitError("expected answer keys, got none")
    if not students:
        raise GradekitError("expected a roster with students, got none")
    titles = dict(problem_titles or {})
    skip = out if out.resolve().is_relative_to(submissions.resolve()) else None
    intake = read_submissions(submissions, students, keys, skip=skip)
    grades = grade_students(keys, students, intake.chosen)
    flags = find_copies(grades, keys)
    _prepare_out(out, submissions)
    problems = list(dict.fromkeys(e.problem for e in keys))
    written: list[Path] = []

    def done(path: Path) -> Path:
        written.append(path)
        return path

    write_grades(done(out / "grades.csv"), grades, problems, titles)
    write_canvas(done(out / "canvas.csv"), grades, assignment_title)
    write_moodle(done(out / "moodle.csv"), grades, assignment_title)
    names = safe_names(s.student_id for s in students)
    feedback = out / "feedback"
    for g in grades:
        stem = names[g.student.student_id]
        write_text(done(feedback / f"{stem}.md"), feedback_markdown(g, titles, assignment_title, reveal))
        write_text(done(feedback / f"{stem}.html"), feedback_html(g, titles, assignment_title, reveal))
    image = None
    if histogram:
        percents = [g.percent for g in grades if g.submission is not None]
        write_histogram(done(out / "histogram.png"), percents, assignment_title)
        image = "histogram.png"
    files = [(f.path, f.status, f.detail) for f in intake.files]
    report = report_markdown(
        assignment_title=assignment_title, grades=grades, files=files, flags=flags, histogram=image
    )
    write_text(done(out / "report.md"), report)
    return BatchResult(tuple(grades), intake.files, tuple(flags), out, tuple(written))
