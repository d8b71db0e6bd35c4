"""What Canvas and Moodle read and write: their download names, grade-import CSVs and bulk feedback zips.

The names follow the LMSs' own code: Canvas names a downloaded submission
``lastfirst[_LATE]_<user id>_<attachment id>_<uploaded name>`` and its "Re-upload submissions"
takes the first two all-digit ``_`` parts of a file name as (user id, attachment id)
(``Assignment#infer_comment_context_from_filename``); Moodle names a participant's folder
``<Full Name>_<participant id>_assignsubmission_file[_]`` (underscores of the name made spaces) and
its "Upload multiple feedback files in a zip" reads the participant id as the second of at most
five ``_`` parts of a path part (``assignfeedback_file_zip_importer::is_valid_filename_for_import``).
"""

from __future__ import annotations

import io
import re
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gradekit.csvsafe import atomic_write, write_csv

if TYPE_CHECKING:  # the reader imports this module for the LMS names, and compare imports the reader
    from gradekit.grading.compare import StudentGrade


@dataclass(frozen=True)
class LmsName:
    """A file or folder name an LMS download gave a student's submission.

    ``lms`` is ``canvas`` or ``moodle``; ``name`` the student's name as the LMS wrote it; ``uid``
    the LMS's own id of the student (Canvas user id, Moodle participant id: never a student
    number); ``prefix`` the part of the name up to and with the ids (Canvas ``ivyjones_123_456_``,
    Moodle the whole folder name); ``rest`` the file name the student uploaded (Canvas, and
    Moodle's flat layout), or empty for a Moodle folder.
    """

    lms: str
    name: str
    uid: str
    prefix: str
    rest: str


_CANVAS = re.compile(
    r"(?P<name>[^\W\d_]+(?:[_ -][^\W\d_]+)*?)_(?:late_)?(?P<uid>\d+)_(?P<attachment>\d+)_(?P<rest>.+)",
    re.IGNORECASE | re.DOTALL,
)
_MOODLE_PLUGIN = re.compile(r"assign(?:submission|feedback)", re.IGNORECASE)


def lms_name(part: str) -> LmsName | None:
    """The Canvas or Moodle download name *part* (one path part), or None for any other name.

    Moodle's rule is its importer's: split at ``_`` into at most five pieces, the second all
    digits, the third the plugin type (``assignsubmission``), the fourth its name; Canvas's is a
    name of letters, an optional ``LATE``, then two numbers.
    """
    pieces = part.split("_", 4)
    if len(pieces) >= 4 and pieces[1].isdigit() and pieces[1].isascii() and pieces[0] and pieces[3] \
            and _MOODLE_PLUGIN.fullmatch(pieces[2]):
        rest = pieces[4] if len(pieces) == 5 else ""
        return LmsName("moodle", pieces[0], pieces[1], part[: len(part) - len(rest)], rest)
    m = _CANVAS.fullmatch(part)
    if m and m["uid"].isascii() and m["attachment"].isascii():
        return LmsName("canvas", m["name"], m["uid"], part[: m.start("rest")], m["rest"])
    return None


def _parts(path: str) -> list[str]:
    return [p for p in re.split(r"[/\\]+", path) if p]


def canvas_name(path: str) -> LmsName | None:
    """The Canvas download name of a submission's file (its own name only: a folder of the
    instructor's never counts), or None."""
    parts = _parts(path)
    found = lms_name(parts[-1]) if parts else None
    return found if found is not None and found.lms == "canvas" else None


def moodle_name(path: str) -> LmsName | None:
    """The Moodle download name nearest a submission's file: its participant's folder or, in the
    flat layout, the file's own name; None when there is none."""
    for part in reversed(_parts(path)):
        found = lms_name(part)
        if found is not None and found.lms == "moodle":
            return found
    return None


def submitted_name(path: str) -> str:
    """The name of a submitted file as the student uploaded it: no folder, no LMS prefix."""
    parts = _parts(path)
    if not parts:
        return ""
    found = lms_name(parts[-1])
    return found.rest if found is not None and found.rest else parts[-1]


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]+")


def one_line(text: str) -> str:
    """*text* as one line for an LMS cell: newlines, tabs and control characters become one space."""
    return " ".join(_CONTROL.sub(" ", str(text)).split())


def points(value: float) -> float | int:
    """Points as written to CSVs: whole numbers as int, otherwise rounded to 4 decimals."""
    rounded = round(value, 4)
    return int(rounded) if rounded == int(rounded) else rounded


def canvas_user_id(grade: StudentGrade) -> str:
    """The student's Canvas user id: the roster's (a Canvas gradebook export), else the one in the
    name Canvas gave their submission; empty when neither knows it."""
    if grade.student.lms_id:
        return grade.student.lms_id
    found = canvas_name(grade.submission.path) if grade.submission is not None else None
    return found.uid if found is not None else ""


def canvas_column(assignment_title: str, assignment_id: str = "") -> str:
    """The grade column's header for Canvas: ``<title> (<assignment id>)`` matches the existing
    assignment; a bare title makes Canvas offer to create a new column."""
    title = one_line(assignment_title)
    return f"{title} ({assignment_id})" if assignment_id else title


def write_canvas(path: Path, grades: Sequence[StudentGrade], assignment_title: str, assignment_id: str = "") -> None:
    """Canvas gradebook import: ``Student, ID, SIS User ID, SIS Login ID, Section, <title> (<id>)``.

    Canvas matches a row by ``ID`` (its own user id: from a Canvas roster, else from the name
    Canvas gave the submission's file), else ``SIS User ID`` (the student id, left empty when the
    roster had none and the id is Canvas's own), else ``SIS Login ID``; ``Student`` is only shown,
    the name as the roster gave it (never cut at a space); the grade is the points total.
    """
    header = ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", canvas_column(assignment_title, assignment_id)]
    rows = []
    for g in grades:
        s = g.student
        sis = "" if s.lms_id and s.student_id == s.lms_id else s.student_id
        rows.append([one_line(s.name), one_line(canvas_user_id(g)), one_line(sis), one_line(s.sis_login),
                     one_line(s.section), points(g.total)])
    write_csv(path, header, rows)


def write_moodle(path: Path, grades: Sequence[StudentGrade], assignment_title: str) -> None:
    """Moodle grade import (Grades > Import > CSV file): ``ID number,Email address,<title>``.

    In Moodle's import dialog the instructor maps either column: ``ID number`` to "ID number" or
    ``Email address`` to "Email address", and the title column to the grade item; the grade is the
    points total.
    """
    header = ["ID number", "Email address", one_line(assignment_title)]
    rows = [[one_line(g.student.student_id), one_line(g.student.email), points(g.total)] for g in grades]
    write_csv(path, header, rows)


FEEDBACK_FILE = "feedback.html"


def moodle_folder(grade: StudentGrade) -> str | None:
    """The folder Moodle's feedback zip import files *grade*'s feedback under: the participant's
    download folder (``Full Name_12345_assignsubmission_file_``), or None when the student's
    submission did not come from a Moodle download."""
    found = moodle_name(grade.submission.path) if grade.submission is not None else None
    if found is None:
        return None
    return f"{found.name}_{found.uid}_assignsubmission_file_"


def canvas_feedback_name(grade: StudentGrade) -> str | None:
    """The name Canvas's "Re-upload submissions" files *grade*'s feedback under as a submission
    comment: the submission's Canvas prefix (``ivyjones_123_456_``) and ``feedback.html``; None
    when the student's file did not come from a Canvas download."""
    found = canvas_name(grade.submission.path) if grade.submission is not None else None
    return None if found is None else found.prefix + FEEDBACK_FILE


def write_feedback_zip(
    path: Path, grades: Sequence[StudentGrade], page: Callable[[StudentGrade], str],
    name: Callable[[StudentGrade], str | None],
) -> list[str]:
    """A zip of each student's feedback *page* under the *name* the LMS files it by (students it
    names None are left out, as are two students given one name). Returns the ids left out."""
    buffer = io.BytesIO()
    taken: set[str] = set()
    left = []
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        for g in grades:
            member = name(g)
            if member is None or member in taken:
                left.append(g.student.student_id)
                continue
            taken.add(member)
            info = zipfile.ZipInfo(member, date_time=(1980, 1, 1, 0, 0, 0))  # the same bytes every run
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, page(g))
    atomic_write(path, buffer.getvalue())
    return left


def moodle_feedback_member(grade: StudentGrade) -> str | None:
    """`moodle_folder` with the feedback file in it."""
    folder = moodle_folder(grade)
    return None if folder is None else f"{folder}/{FEEDBACK_FILE}"
