"""The online page's one way into the grading core: every call gradekit.web makes into it is here.

A student's answers on the page are an answers CSV in the layout of the template `generate` writes
(``student_id,key,value,unit``, a row per key, the key's unit filled in), read by the same reader as
a submitted file (`read_file`), graded by `gradekit.grading.compare.grade_student` (`grade_class`,
which `grade_batch` runs over the class, for one student) with the assignment's partial credit and
then its carried-forward credit, against the keys frozen in ``keys.json``, and explained by the same
feedback rows (`feedback_pages`). The instructor's downloads are `gradekit.grade` itself run over
those CSV files, so they are what ``gradekit grade`` writes from them.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from gradekit.assignment import Assignment, check_manifest, frozen_keys, load_assignment
from gradekit.csvsafe import write_csv
from gradekit.errors import GradekitError
from gradekit.grading.compare import StudentGrade, grade_student
from gradekit.grading.feedback import feedback_pages
from gradekit.grading.reader import EXPECTED, IdIndex, KeyIndex, Submission, read_file
from gradekit.numbers import fmt
from gradekit.roster import Student, read_roster, safe_names
from gradekit.solving.keys import KeyEntry
from gradekit.units import with_unit

log = logging.getLogger(__name__)

HEADER = EXPECTED.split(",")  # the answer template's columns
Row = tuple[str, str, str]  # (key, value, unit) as the student typed them


@dataclass(frozen=True)
class Paths:
    """What a course is served from (recorded in the database, so `export` needs only its URL)."""

    assignment: str
    roster: str
    manifest: str


class Course:
    """One served class: the assignment, roster and frozen keys, loaded once per server process.

    Raises:
        GradekitError: a bad assignment, roster or manifest, or a manifest without frozen keys.
    """

    def __init__(self, paths: Paths) -> None:
        self.paths = paths
        manifest = Path(paths.manifest)
        self.assignment: Assignment = load_assignment(paths.assignment)
        self.students: list[Student] = read_roster(Path(paths.roster))
        for note in check_manifest(self.assignment, manifest):
            log.warning("warning: %s (the page grades against the keys frozen at generation)", note)
        frozen = frozen_keys(manifest)
        if frozen is None:
            raise GradekitError("expected a manifest with frozen keys (keys.json); run gradekit generate again",
                                path=str(manifest))
        self.by_id = {s.student_id: s for s in self.students if s.student_id in frozen}
        self._keys: Mapping[str, list[KeyEntry]] = frozen
        self.titles = {it.label: f"{it.label}: {it.problem.title}" for it in self.assignment.items}
        self._ids = IdIndex(self.students)
        self._key_index = KeyIndex(dict.fromkeys(e.key for sid in self.by_id for e in frozen[sid]))
        self._partial = self.assignment.partial_credit()  # as `gradekit grade` gives it
        from gradekit.assignment import redraws_from_manifest
        from gradekit.grading.carried import class_carry

        ids = list(self.by_id)
        keys = [e for sid in ids for e in frozen[sid]]
        self._carry = class_carry(self.assignment, ids, redraws_from_manifest(manifest), keys,  # as `gradekit grade`
                                  lambda note: log.warning("warning: %s", note))
        self._tmp = Path(tempfile.mkdtemp(prefix="gradekit-serve-"))

    def close(self) -> None:
        shutil.rmtree(self._tmp, ignore_errors=True)

    def entries(self, student_id: str) -> list[KeyEntry]:
        """The student's key entries, in the sheet's order (their values never leave the server before the due date)."""
        return self._keys[student_id]

    def rows(self, student_id: str, answers: Mapping[str, tuple[str, str]]) -> list[list[str]]:
        """The answers CSV's rows: one per key, as the template has them (the key's unit when none was typed)."""
        out = []
        for e in self.entries(student_id):
            value, unit = answers.get(e.key, ("", e.unit))
            out.append([student_id, e.key, value, unit])
        return out

    def grade(self, student_id: str, answers: Mapping[str, tuple[str, str]],
              display: str = "answers.csv") -> StudentGrade:
        """Grade *answers* (``{key: (value, unit)}``) as `gradekit grade` grades the same answers.csv."""
        path = self._tmp / f"{uuid.uuid4().hex}.csv"
        write_csv(path, HEADER, self.rows(student_id, answers))
        try:
            sub = self._read(path, display, student_id)
        finally:
            os.unlink(path)
        return self._graded(student_id, sub)

    def read_as(self, student_id: str, answers: Mapping[str, tuple[str, str]]) -> dict[str, str]:
        """How the reader reads each non-blank answer: its value in the key's unit, or why it cannot be read;
        never whether it is right (that is what an attempt is for)."""
        grade = self.grade(student_id, answers)
        return {r.entry.key: with_unit(fmt(r.value, 6), r.entry.unit) if r.value is not None else r.message
                for r in grade.results if answers.get(r.entry.key, ("", ""))[0].strip()}

    def read_upload(self, student_id: str, data: bytes, filename: str) -> Submission | None:
        """What the reader reads of an uploaded file for this student (None: nothing of theirs in it)."""
        path = self._tmp / f"{uuid.uuid4().hex}.csv"
        path.write_bytes(data)
        try:
            return self._read(path, filename, student_id)
        finally:
            os.unlink(path)

    def _read(self, path: Path, display: str, student_id: str) -> Submission | None:
        # the file stands as the student's own (named for them), as a file of theirs in a submissions folder
        subs = read_file(path, display, f"{student_id}.csv", self._ids, self._key_index)
        return next((s for s in subs if s.student_id == student_id), None)

    def _graded(self, student_id: str, sub: Submission | None) -> StudentGrade:
        g = grade_student(self.by_id[student_id], self.entries(student_id), sub, self._partial)
        return self._carry.apply(g) if self._carry is not None else g

    def feedback(self, grade: StudentGrade, reveal: bool) -> str:
        """The body of the student's HTML feedback page (the feedback file's rows, every text escaped). The
        page's answers are the attempts the student made on it (typed, or read from an upload they saw
        first), kept as an answers CSV of the page's own making: no file of theirs to name or to report
        problems in (a blank answer reads "not graded" in its row)."""
        page = feedback_pages(grade, self.titles, self.assignment.title, reveal, self.assignment.feedback,
                              file=False)[1]
        start, end = page.find("<body>"), page.rfind("</body>")
        return page[start + len("<body>"):end]


MARKER = ".gradekit-online"  # in a folder export writes (whose submissions/ it may empty again)


def export(course: Course, answers: Mapping[str, Mapping[str, tuple[str, str]]], out: Path) -> object:
    """Write each student's current answers as ``OUT/submissions/<safe id>.csv`` and run `gradekit.grade`
    on them into ``OUT/graded`` (grades.csv, canvas.csv, moodle.csv, feedback/, report.md): the same bytes
    as ``gradekit grade ASSIGNMENT --roster R --submissions OUT/submissions --out X --manifest M``.

    Returns:
        `gradekit.grade`'s batch result (its ``flags`` are the copy-detection flags).
    """
    import gradekit

    out = Path(out)
    subs = out / "submissions"
    if subs.exists():  # the last export's answers, replaced (the marker says that export wrote them)
        if not (out / MARKER).exists():
            raise GradekitError("expected a folder gradekit export wrote, got another folder", path=str(subs))
        shutil.rmtree(subs)
    subs.mkdir(parents=True)  # nothing but the answers in it: the report lists every file of the folder
    (out / MARKER).write_text("written by gradekit export: submissions/ is rewritten by the next export\n")
    names = safe_names(s.student_id for s in course.students)
    for sid, mine in answers.items():
        if sid in course.by_id and mine:
            write_csv(subs / f"{names[sid]}.csv", HEADER, course.rows(sid, mine))
    if not any(subs.glob("*.csv")):
        raise GradekitError("expected at least one student's answers in the database, got none", path=str(out))
    paths = course.paths
    return gradekit.grade(paths.assignment, paths.roster, subs, out / "graded", manifest=paths.manifest,
                          warn=lambda note: log.warning("warning: %s", note))


def current_answers(attempts: Sequence) -> dict[str, dict[str, tuple[str, str]]]:
    """``{student: {key: (value, unit)}}``: each key's last graded attempt (refused ones never count)."""
    out: dict[str, dict[str, tuple[str, str]]] = {}
    for a in attempts:
        if a.status == "graded":
            out.setdefault(a.student_id, {})[a.key] = (a.value, a.unit)
    return out
