"""Answers checked by hand: the worklist grading writes, and the points the instructor gives back.

An answer the bank marks ``hand_check: true`` is read and shown but never judged by a band (no band
both admits honest work and rejects a wrong answer there: benchmarks/RESULTS.md, "Answers checked by
hand"). `gradekit grade` lists every such answer of every graded student in ``OUT/hand.csv``: what
the student wrote, how it was read, the key and its band, what the answer is worth, and an empty
``points`` column. The instructor fills that column (any rows, any time) and grades again: the points
in ``OUT/hand.csv`` (or in the file ``--hand`` names) enter the student's score and maximum, the
feedback shows them, and the rewritten ``hand.csv`` keeps them. An answer whose points are not given
yet counts in neither.

Points are given to what the student wrote: when a student's answer is no longer the one the row
shows (a new submission), its points are not used, the rewritten row says what they were, and the
report asks for the answer to be checked again.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from gradekit.csvsafe import decode_bytes, sniff_delimiter, unguard, write_csv
from gradekit.errors import GradekitError
from gradekit.grading.compare import StudentGrade
from gradekit.grading.lms import points as csv_points
from gradekit.grading.reader import Answer, Submission, parse_value
from gradekit.roster import header_key
from gradekit.solving.keys import KeyEntry

FILE = "hand.csv"
HEADER = ("student_id", "name", "key", "problem", "answered", "read_as", "key_value", "band", "worth", "points",
          "note")


def write_hand(path: Path, grades: Sequence[StudentGrade], notes: Mapping[tuple[str, str], str] | None = None) -> bool:
    """Write the worklist of answers checked by hand of every graded student (``points``: those given,
    blank where none yet; ``note``: *notes* by student and key, points given to an earlier answer).
    Returns False, writing nothing, when there is none."""
    notes = notes or {}
    rows = []
    for g in grades:
        if g.submission is None and not any(r.entry.hand_check and not r.pending for r in g.results):
            continue  # no file, and no points given by hand (an answer on paper) to keep
        for r in g.results:
            e = r.entry
            if not e.hand_check:
                continue
            rows.append([
                g.student.student_id, g.student.name, e.key, e.problem, answered_text(r.answer),
                "" if r.value is None else _shown(r.value), _shown(e.value), f"{e.tolerance.describe()} ({e.unit})",
                csv_points(e.points), "" if r.pending else csv_points(r.points),
                notes.get((g.student.student_id, e.key), ""),
            ])
    if not rows:
        return False
    write_csv(path, HEADER, rows)
    return True


def _shown(value: float) -> float:
    """*value* to 6 significant figures, a number in the CSV (a spreadsheet sorts and sums it)."""
    return float(f"{value:.6g}")


class Given(NamedTuple):
    """Points the instructor gave one answer, on row ``line``, for what the student wrote then
    (``answered``; None when the file has no such column)."""

    points: float
    answered: str | None
    line: int


def answered_text(answer: Answer | None) -> str:
    """What a student wrote for an answer (`Answer.written`), empty when they left it out."""
    return "" if answer is None else answer.written


def read_hand(path: Path, keys: Sequence[KeyEntry]) -> dict[tuple[str, str], Given]:
    """The points the instructor gave, ``{(student id, key): Given}``, from a filled ``hand.csv``.

    Rows whose ``points`` cell is blank are not checked yet and skipped. Every other row must name a
    student and an answer of theirs the bank marks for checking by hand, once, with points from 0 to
    what the answer is worth.

    Raises:
        GradekitError: the file cannot be read, lacks a column, or a row is wrong (the message names
            the file, the row and the column).
    """
    where = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise GradekitError(f"expected a readable hand.csv, got {exc.strerror or exc}", path=where) from None
    text, _ = decode_bytes(data)
    delimiter = sniff_delimiter(text)
    try:
        rows = list(csv.reader(io.StringIO(text, newline=""), delimiter=delimiter))
    except csv.Error as exc:
        raise GradekitError(f"expected the hand.csv gradekit grade wrote, got unreadable CSV ({exc})",
                            path=where) from None
    if not rows:
        raise GradekitError("expected the hand.csv gradekit grade wrote, got an empty file", path=where)
    header = [header_key(c) for c in rows[0]]
    columns = {}
    for name in ("student_id", "key", "points"):
        if name not in header:
            raise GradekitError(f"expected a {name} column (the header of the hand.csv gradekit grade wrote), got "
                                f"{', '.join(repr(c[:30]) for c in rows[0][:6])}", path=where, line=1)
        columns[name] = header.index(name)
    answered = header.index("answered") if "answered" in header else None
    hand = {(e.student_id, e.key): e for e in keys if e.hand_check}
    own = {(e.student_id, e.key) for e in keys}
    given: dict[tuple[str, str], Given] = {}
    for line, row in enumerate(rows[1:], 2):
        cell = {name: unguard(row[i].strip()) if i < len(row) else "" for name, i in columns.items()}
        if not cell["points"]:
            continue
        sid, key = cell["student_id"], cell["key"]
        entry = hand.get((sid, key))
        if entry is None:
            found = ("an answer graded by its band, not by hand" if (sid, key) in own
                     else "no such student on the roster and answer")
            raise GradekitError(f"expected a student and an answer checked by hand, got {sid!r} {key!r} ({found}: "
                                "delete the row or its points)", path=where, line=line, field="key")
        if (sid, key) in given:
            raise GradekitError(f"expected each answer once, got {sid!r} {key!r} again (first on row "
                                f"{given[sid, key].line})", path=where, line=line, field="key")
        points = _points(cell["points"], delimiter)
        if points is None or not 0 <= points <= entry.points:
            raise GradekitError(f"expected points from 0 to {entry.points:g} (what {key} is worth), got "
                                f"{cell['points']!r}", path=where, line=line, field="points")
        wrote = None if answered is None else (unguard(row[answered].strip()) if answered < len(row) else "")
        given[sid, key] = Given(points, wrote, line)
    return given


def still_given(given: Mapping[tuple[str, str], Given], chosen: Mapping[str, Submission], path: Path | None
                ) -> tuple[dict[tuple[str, str], float], dict[tuple[str, str], str]]:
    """The points that still apply, ``{(student id, key): points}``, and a note for each that does not:
    given for another answer than the one the student's graded submission now holds."""
    points: dict[tuple[str, str], float] = {}
    stale: dict[tuple[str, str], str] = {}
    answers: dict[str, dict[str, Answer]] = {}
    for (sid, key), g in given.items():
        sub = chosen.get(sid)
        if sid not in answers:
            answers[sid] = {a.key: a for a in sub.answers} if sub is not None else {}
        now = answered_text(answers[sid].get(key))
        if g.answered is None or _same(g.answered, now):
            points[sid, key] = g.points
        else:
            stale[sid, key] = (f"{path}:{g.line}: {sid} {key}: {g.points:g} point(s) were given for "
                               f"{g.answered or 'no answer'!r}, the answer is now {now or 'none'!r}: check it again")
    return points, stale


def _same(then: str, now: str) -> bool:
    """The answer a row shows is the student's answer now: the same text, or the same number in the same
    unit (a spreadsheet saves ``0.50`` as ``0.5`` and ``1.2e3`` as ``1200``)."""
    number, _, unit = then.strip().partition(" [")
    number_now, _, unit_now = now.strip().partition(" [")
    if unit != unit_now:
        return False
    if number == number_now:
        return True
    try:
        return float(number) == float(number_now)
    except ValueError:
        return False


def _points(text: str, delimiter: str) -> float | None:
    """A points cell as a number, read as an answer's value is (`parse_value`), or None."""
    try:
        value, unit = parse_value(text, decimal_comma=delimiter != ",")
    except ValueError:
        return None
    return None if unit else value


def file_for(out: Path, hand: Path | None) -> Path | None:
    """The ``hand.csv`` to read the points from: the one named, else OUT's from an earlier run (the
    instructor fills it in place), else none."""
    if hand is not None:
        return Path(hand)
    mine = Path(out) / FILE
    return mine if mine.is_file() else None


def check_kept(out: Path, source: Path | None, given: Mapping[tuple[str, str], Given],
               keys: Sequence[KeyEntry]) -> None:
    """Refuse a run that would replace points given in OUT's ``hand.csv`` with those of another file
    (*source*, read into *given*) that lacks or changes them.

    Raises:
        GradekitError: naming OUT's file, how many of its points would be lost and the first one.
    """
    mine = Path(out) / FILE
    if source is None or not mine.is_file() or mine.resolve() == Path(source).resolve():
        return
    lost = [(k, g) for k, g in read_hand(mine, keys).items() if k not in given or given[k].points != g.points]
    if lost:
        (sid, key), g = lost[0]
        raise GradekitError(
            f"expected its points given by hand in {source} too, got {len(lost)} only here (first {sid} {key}: "
            f"{g.points:g}, row {g.line}); grade with --hand naming this file, or copy them over",
            path=str(mine))
