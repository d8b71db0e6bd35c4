"""Grade a folder of submissions against the keys and write every output: one call for the CLI."""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from gradekit.csvsafe import StagedFolder, os_errors
from gradekit.errors import GradekitError
from gradekit.grading.archive import submissions_folder
from gradekit.grading.compare import StudentGrade, grade_class, grade_student
from gradekit.grading.exports import DEFAULT_EXPORTS, GradedClass, choose_exports, write_exports
from gradekit.grading.feedback import md_cell
from gradekit.grading.hand import FILE as HAND_FILE
from gradekit.grading.hand import check_kept, file_for, read_hand, still_given
from gradekit.grading.integrity import IntegrityFlag, find_copies
from gradekit.grading.reader import IdIndex, KeyIndex, Submission, read_file, special_kind
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, PartialCredit

MARKER = ".gradekit-output"
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FileRecord:
    """What became of one file of the submissions folder.

    ``status`` is one of ``graded``, ``unreadable``, ``unknown student``, ``duplicate`` (another
    file of the same student was graded), ``ignored`` (hidden and system files) or ``skipped``
    (symbolic links, FIFOs, devices and sockets: reported, never opened).
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
    hand_notes: tuple[str, ...] = ()  # points given by hand to an answer the student has since changed

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

    def attention(self) -> list[str]:
        """What needs the instructor's look before the grades go out, one line each, naming the student
        and the file: unreadable files, files tied to no student, a file naming another student inside,
        and answers that could not be read or were not given."""
        lines = [f"unreadable file: {f.detail if f.detail.startswith(f.path) else f'{f.path}: {f.detail}'}"
                 for f in self.files if f.status == "unreadable"]
        lines += [f"no student: {f.path}: {f.detail}" for f in self.files if f.status == "unknown student"]
        lines += [f"conflict: {flag.describe()}" for flag in self.flags if isinstance(flag, IdConflict)]
        lines += [f"check by hand again: {note}" for note in self.hand_notes]
        for g in self.grades:
            if g.submission is not None and g.submission.readable and g.issues:
                first = g.issues[0]
                more = f" (+{len(g.issues) - 1} more)" if len(g.issues) > 1 else ""
                lines.append(f"answers not read: {g.student.student_id} ({g.student.display}): {first}{more}")
        return lines

    @property
    def clean(self) -> bool:
        """Every file was read without a message and matched a student; nobody is missing."""
        return (
            all(f.status in ("graded", "ignored") for f in self.files)
            and not self.missing
            and not any(g.issues for g in self.grades)
        )


@dataclass(frozen=True)
class IdConflict(IntegrityFlag):
    """A file whose name points to one student (``student_id``) while its id column names another
    (``other_id``): graded as the first only; ``own_matches``/``other_matches`` count its answers
    within tolerance of each one's key."""

    def describe(self) -> str:
        return (
            f"{self.path}: the file name points to {self.student_id} but its student_id column says "
            f"{self.other_id}; graded as {self.student_id} only ({self.own_matches} answers fit "
            f"{self.student_id}'s key, {self.other_matches} fit {self.other_id}'s); {self.other_id}'s "
            "own submission is not replaced by it"
        )


def _hidden(name: str) -> bool:
    return name.startswith((".", "~$")) or name in ("__MACOSX", "Thumbs.db", "desktop.ini")


def printable(path: str) -> str:
    """A path as text that can be printed and written (undecodable bytes of a name shown as �)."""
    return os.fsencode(path).decode("utf-8", errors="replace")


def read_submissions(
    submissions: Path, students: Sequence[Student], keys: Sequence[KeyEntry], *, skip: Path | None = None,
    shown: str | None = None,
) -> Intake:
    """Read every file below *submissions* and choose one submission per student.

    Several files for one student: one whose name points to the student wins over one that only
    names them inside, then a readable one over an unreadable one, then the most recently
    modified, then the last by path; the others are recorded as duplicates. Symbolic links,
    FIFOs, devices and sockets are recorded as ``skipped`` and never opened.

    Args:
        submissions: the folder (read only; searched recursively, symlinked folders not followed).
        students: the roster.
        keys: every student's key entries (their key names are the ones a file may answer).
        skip: a folder inside *submissions* not to read (the output folder).
        shown: how the folder is named in messages (an LMS zip's name when it was unpacked); the folder.

    Returns:
        The chosen submission per student id and one record per file.

    Raises:
        GradekitError: *submissions* is not a readable folder.
    """
    files, ignored = _walk(submissions, skip, shown)
    ids = IdIndex(students)
    key_index = KeyIndex(e.key for e in keys)
    per_file = [(display, read_file(path, display, relative, ids, key_index)) for path, display, relative in files]
    chosen = _choose(sub for _, subs in per_file for sub in subs)
    records = [_record(display, subs, chosen) for display, subs in per_file]
    return Intake(chosen, tuple(records + ignored))


def _walk(
    submissions: Path, skip: Path | None, shown: str | None = None
) -> tuple[list[tuple[Path, str, str]], list[FileRecord]]:
    """The regular files below *submissions* to read, as (path, path to print, path below the
    folder), and a record of each thing that is not read (hidden, special, linked, *skip*)."""
    if not submissions.is_dir():
        raise GradekitError("expected a folder of submission CSVs, got none there", path=str(submissions))
    skip_real = os.path.realpath(skip) if skip is not None else None

    def _shown(path: str) -> str:
        return printable(path if shown is None else os.path.join(shown, os.path.relpath(path, submissions)))

    files: list[tuple[Path, str, str]] = []
    ignored: list[FileRecord] = []
    for root, dirs, names in os.walk(submissions):
        below = os.path.relpath(root, submissions)  # the folder's path below the submissions folder
        dirs.sort()
        for d in list(dirs):
            full = os.path.join(root, d)
            if os.path.islink(full):
                dirs.remove(d)
                ignored.append(FileRecord(_shown(full) + os.sep, "skipped", "a symbolic link: not followed"))
            elif _hidden(d) or (skip_real and os.path.realpath(full) == skip_real):
                dirs.remove(d)
                ignored.append(FileRecord(_shown(full) + os.sep, "ignored", "folder not read"))
        for name in sorted(names):
            path = Path(root) / name
            display = _shown(str(path))
            if _hidden(name):
                ignored.append(FileRecord(display, "ignored", "hidden or system file"))
                continue
            try:
                kind = special_kind(os.lstat(path).st_mode)
            except OSError as exc:
                kind = f"unreadable ({exc.strerror or exc})"
            if kind:
                ignored.append(FileRecord(display, "skipped", f"{kind}: not opened"))
                continue
            files.append((path, display, printable(name if below == os.curdir else os.path.join(below, name))))
    if not files and not ignored:
        raise GradekitError(
            "expected submission files in this folder, got an empty folder", path=str(submissions)
        )
    return files, ignored


def _choose(subs: Iterable[Submission]) -> dict[str, Submission]:
    """The submission graded for each student of *subs* (see `read_submissions`)."""
    by_student: dict[str, list[Submission]] = {}
    for sub in subs:
        if sub.student_id is not None:
            by_student.setdefault(sub.student_id, []).append(sub)
    # A file named for the student beats one that only names them inside (no one's submission is
    # replaced by a file their own name does not point to); then readable; then the newest.
    return {
        sid: max(subs, key=lambda s: (s.by_name, s.readable, s.mtime, s.path)) for sid, subs in by_student.items()
    }


def _record(display: str, subs: list[Submission], chosen: dict[str, Submission]) -> FileRecord:
    graded = [s.student_id for s in subs if s.student_id and chosen[s.student_id] is s and s.readable]
    dupes = [s.student_id for s in subs if s.student_id and chosen[s.student_id] is not s]
    unknown = sorted({c for s in subs if s.student_id is None for c in s.claimed})
    unreadable = [s for s in subs if not s.readable]
    parts = [
        f"named for {s.named} but holds rows for {', '.join(s.conflicts)}: graded as {s.named} only"
        for s in subs
        if s.conflicts
    ]
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
    return grade_class(students, _entries(keys), chosen)


def _entries(keys: Iterable[KeyEntry]) -> dict[str, list[KeyEntry]]:
    """Each student's key entries, in order."""
    entries: dict[str, list[KeyEntry]] = {}
    for e in keys:
        entries.setdefault(e.student_id, []).append(e)
    return entries


def _check_out(out: Path, submissions: Path) -> None:
    """Refuse an output folder that is a file, the submissions folder or a folder of someone else's files."""
    if out.resolve() == submissions.resolve():
        raise GradekitError("expected an output folder other than the submissions folder", path=str(out))
    if out.exists() and not out.is_dir():
        raise GradekitError("expected an output folder, got a file", path=str(out))
    if out.is_dir() and not (out / MARKER).exists() and any(
        not p.name.startswith(StagedFolder.PARTIAL) for p in out.iterdir()  # a killed run's staging is ours
    ):
        raise GradekitError(
            "expected an empty output folder or one gradekit wrote before, got a folder of other files "
            "(choose another --out)",
            path=str(out),
        )


def _conflicts(
    grades: Sequence[StudentGrade], entries: Mapping[str, list[KeyEntry]], students: Sequence[Student]
) -> list[IntegrityFlag]:
    """One `IdConflict` per (file, other student) for every graded file that names someone else inside."""
    by_id = {s.student_id: s for s in students}
    flags: list[IntegrityFlag] = []
    for g in grades:
        sub = g.submission
        if sub is None or not sub.conflicts:
            continue
        own = sum(r.correct for r in g.results)
        for other in sub.conflicts:
            theirs = grade_student(by_id[other], entries.get(other, []), sub) if other in by_id else None
            fit = sum(r.correct for r in theirs.results) if theirs else 0
            matched = tuple(r.entry.key for r in theirs.results if r.correct) if theirs else ()
            flags.append(IdConflict(g.student.student_id, other, sub.path, own, fit, matched))
    return flags


def _attention(grades: Sequence[StudentGrade], conflicts: Sequence[IntegrityFlag], files: Sequence[FileRecord],
               hand_notes: Sequence[str] = ()) -> str:
    """The report's first section: students whose grade needs a look before anything else."""
    names = {g.student.student_id: g.student.name for g in grades}
    lines = list(hand_notes)
    pending = pending_by_hand(grades)
    if pending:
        lines.append(f"{pending} answer(s) to check by hand: their points leave the scores until you give them in "
                     f"the points column of {HAND_FILE} and grade again")
    for f in conflicts:
        lines.append(
            f"{f.student_id} {names.get(f.student_id, '')} and {f.other_id} {names.get(f.other_id, '')}: "
            f"{f.path} is named for {f.student_id} but its student_id column says {f.other_id} "
            f"(graded as {f.student_id} only; see Integrity flags)"
        )
    for g in grades:
        if g.submission is not None and not g.submission.readable:
            why = str(g.submission.issues[0]) if g.submission.issues else g.submission.path
            lines.append(f"{g.student.student_id} {g.student.name}: submitted an unreadable file ({why})")
    skipped = [f for f in files if f.status == "skipped"]
    if skipped:
        lines.append(f"{len(skipped)} special file(s) skipped without being opened (see Files)")
    if not lines:
        return ""
    return "\n".join(["## Check first", "", *("- " + md_cell(line) for line in lines), "", ""])


def pending_by_hand(grades: Sequence[StudentGrade]) -> int:
    """How many answers of graded submissions wait for points given by hand."""
    return sum(r.pending for g in grades if g.submission is not None for r in g.results)


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
    hint: str = "direction",
    carry=None,
    partial: Mapping[str, PartialCredit] | None = None,
    exports: Sequence[str] | None = None,
    canvas_assignment_id: str = "",
    hand: Path | None = None,
) -> BatchResult:
    """Grade every submission in a folder and write grades, LMS imports, feedback and a report.

    Writes ``OUT/grades.csv``, ``OUT/canvas.csv``, ``OUT/moodle.csv``,
    ``OUT/feedback/<safe id>.md`` and ``.html`` per roster student, ``OUT/report.md`` and
    ``OUT/histogram.svg``. Everything is written into a hidden folder beside OUT first and moved
    in only when complete (`StagedFolder`): after an error or Ctrl-C, OUT is still the previous
    complete run; feedback of students no longer on the roster is removed. The submissions folder
    is only read. A bad submission never raises: it scores what can be read and its messages go
    to the feedback and the report.

    Args:
        keys: every student's key entries.
        students: the roster.
        submissions: the folder of submission files, or an LMS's zip of them (`submissions_folder`).
        out: the output folder (created; must be empty or a previous gradekit output).
        assignment_title: the assignment's name (the LMS grade column and the headings).
        reveal: show the correct values in the feedback.
        problem_titles: display names per ``KeyEntry.problem`` (defaults to the problem id).
        histogram: draw ``histogram.svg``.
        hint: what feedback without *reveal* says of a wrong answer: ``direction`` or ``band``.
        carry: carried-forward credit (`gradekit.grading.carried.CarryForward`), applied to each
            grade before its feedback is written; grades.csv then counts carried answers and the
            report has a section on them.
        partial: partial credit per problem (`PartialCredit`, by ``KeyEntry.problem``): an answer within
            that wider band earns its share of the points, and its feedback says so.
        exports: what to write, names of `gradekit.grading.exports.EXPORTS` (None: `DEFAULT_EXPORTS`, without
            the histogram when *histogram* is False).
        canvas_assignment_id: the Canvas assignment canvas.csv's grade column names (``<title> (<id>)``).
        hand: a filled ``hand.csv`` (`gradekit.grading.hand`): the points given to answers checked by hand
            (None: OUT's ``hand.csv`` of an earlier run, when there is one, filled in place).

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
    with submissions_folder(submissions) as folder:
        shown = None if folder == submissions else str(submissions)
        intake = read_submissions(folder, students, keys, skip=skip, shown=shown)
    _check_out(out, submissions)
    source = file_for(out, hand)
    read = read_hand(source, keys) if source is not None else {}
    check_kept(out, source, read, keys)
    given, stale = still_given(read, intake.chosen, source)
    entries = _entries(keys)
    grades = grade_class(students, entries, intake.chosen, partial, given)
    if carry is not None:
        grades = [carry.apply(g) for g in grades]
    problems = list(dict.fromkeys(e.problem for e in keys))
    conflicts = _conflicts(grades, entries, students)
    flags = conflicts + find_copies(grades, keys)
    chosen = choose_exports(exports) if exports is not None else tuple(
        e for e in DEFAULT_EXPORTS if histogram or e != "histogram")
    if given or stale:  # hand.csv holds the instructor's points: rewritten, never dropped by the exports chosen
        chosen = choose_exports([*chosen, "hand"])
    graded = GradedClass(
        grades, problems, titles, assignment_title, reveal, hint, carried=carry is not None,
        carry_limits=carry.limits() if carry is not None else (),
        files=[(f.path, f.status, f.detail) for f in intake.files], flags=flags,
        attention=_attention(grades, conflicts, intake.files, list(stale.values())),
        canvas_assignment_id=canvas_assignment_id, hand_notes=stale,
    )
    with StagedFolder(out, MARKER) as stage, os_errors(out):
        write_exports(stage.root, graded, chosen)
        written = stage.commit(
            "gradekit grading output; files listed here are rewritten by the next run, others are left alone",
            extra_previous=() if stage.previous() else _unlisted_outputs(out),
        )
    return BatchResult(tuple(grades), intake.files, tuple(flags), out, tuple(written), tuple(stale.values()))


def _unlisted_outputs(out: Path) -> list[str]:
    """What an older gradekit wrote into OUT without a listing: the fixed names and the feedback."""
    if not (out / MARKER).is_file():
        return []
    fixed = ["grades.csv", "canvas.csv", "moodle.csv", "report.md", "histogram.png", "moodle-feedback.zip",
             "canvas-feedback.zip"]
    feedback = sorted(
        f"feedback/{p.name}" for p in (out / "feedback").glob("*") if p.suffix in (".md", ".html") and p.is_file()
    )
    return [*fixed, *feedback]
