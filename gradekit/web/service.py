"""What the online page does, without HTTP: sign-ins, submissions and their attempts, the instructor's views, export.

`gradekit.web.app` turns requests into these calls and their results into pages; `gradekit export`
calls `Service.export` directly.
"""

from __future__ import annotations

import datetime as dt
import fcntl
import json
import time
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from gradekit.csvsafe import write_csv
from gradekit.errors import GradekitError
from gradekit.web import db
from gradekit.web.access import code_matches, hash_password, load_secret, password_matches
from gradekit.web.grading import Course, Paths, current_answers, export

if TYPE_CHECKING:
    from gradekit.grading.compare import StudentGrade

MAX_VALUE = 200  # characters of a typed value or unit kept (the reader refuses longer cells anyway)
EXPORT_FOLDER = "online-export"  # beside the manifest: the page's downloads


def utc(seconds: float) -> str:
    """A time as the page and the exports print it (UTC, to the second)."""
    return dt.datetime.fromtimestamp(seconds, dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")


@dataclass(frozen=True)
class Outcome:
    """What became of one typed answer of a submission."""

    key: str
    status: str  # graded | refused
    reason: str = ""
    number: int | None = None


@dataclass(frozen=True)
class Receipt:
    """A stored submission: its id, time and each typed answer's fate (``replayed``: that form was stored before)."""

    submission_id: int
    at: float
    outcomes: tuple[Outcome, ...]
    replayed: bool = False


@dataclass(frozen=True)
class AnswerState:
    """One row of a student's answer table."""

    key: str
    description: str
    unit: str
    sign: str
    points: float
    precision: str
    value: str
    typed_unit: str
    used: int
    left: int
    verdict: str  # right | wrong | not graded | "" (no answer yet)
    refused: int


@dataclass(frozen=True)
class StudentPage:
    rows: tuple[AnswerState, ...]
    grade: StudentGrade
    score: float  # with the attempt penalty
    closed: bool
    reveal: bool
    feedback: str  # the feedback page's body (escaped HTML)


@dataclass
class Dashboard:
    students: list[dict] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    items: list[dict] = field(default_factory=list)
    submissions: int = 0
    last_export: dict | None = None


def precision(entry) -> str:  # noqa: ANN001 (a KeyEntry)
    """The precision asked, as the student may read it: the tolerance without an absolute floor (a floor
    is scaled to the problem's numbers and would hint at the key's size)."""
    t = entry.tolerance
    if t.mode == "relative" and not t.period:
        return f"±{t.rel * 100:g} %"
    return t.describe()


class Service:
    """A served course: its grading (`Course`), database and secret."""

    def __init__(self, paths: Paths, database: db.Database, *, create_secret: bool = False) -> None:
        self.paths = paths
        self.database = database
        self.secret = load_secret(Path(paths.manifest), create=create_secret)
        self.course = Course(paths)
        online = self.course.assignment.online
        self.online = online
        self.due = dt.datetime.fromisoformat(online.due).timestamp() if online.due else None

    def close(self) -> None:
        self.course.close()
        self.database.dispose()

    # --- time ------------------------------------------------------------------------------------

    def closed(self, now: float | None = None) -> bool:
        """After the due date: the page is read-only."""
        return self.due is not None and (now or time.time()) > self.due

    def reveal(self, now: float | None = None) -> bool:
        """Whether the page shows the key: only after the due date, and only when the assignment says so."""
        return self.closed(now) and self.online.late_policy == "show-key"

    # --- sign-in ---------------------------------------------------------------------------------

    def sign_in_student(self, student_id: str, code: str, client: str) -> str:
        """``ok``, ``wrong`` or ``limited`` (too many failures: not even checked)."""
        student_id = student_id.strip()[:200]
        with self.database.writing() as conn:
            if not db.sign_in_allowed(conn, student_id, client):
                return "limited"
            ok = student_id in self.course.by_id and code_matches(self.secret, student_id, code)
            db.record_sign_in(conn, student_id, client, ok)
        return "ok" if ok else "wrong"

    def sign_in_instructor(self, password: str, client: str) -> str:
        with self.database.writing() as conn:
            if not db.sign_in_allowed(conn, "instructor", client):
                return "limited"
            stored = db.get_setting(conn, "instructor_password")
        ok = stored is not None and password_matches(stored, password)  # scrypt outside the lock
        with self.database.writing() as conn:
            db.record_sign_in(conn, "instructor", client, ok)
        return "ok" if ok else "wrong"

    # --- a student's page ------------------------------------------------------------------------

    def page(self, student_id: str, now: float | None = None) -> StudentPage:
        with self.database.reading() as conn:
            history = db.student_attempts(conn, student_id)
        return self._page(student_id, history, now)

    def _page(self, student_id: str, history: list[db.Attempt], now: float | None = None,
              grade: StudentGrade | None = None) -> StudentPage:
        """The page of *history*; *grade*: its current answers' grade, when made already."""
        current = current_answers(history).get(student_id, {})
        if grade is None:
            grade = self.course.grade(student_id, current)
        used = Counter(a.key for a in history if a.status == "graded")
        refused = Counter(a.key for a in history if a.status == "refused")
        number = {a.key: a.number for a in history if a.status == "graded"}
        results = {r.entry.key: r for r in grade.results}
        rows = []
        score = 0.0
        for e in self.course.entries(student_id):
            r = results[e.key]
            value, unit = current.get(e.key, ("", e.unit))
            if e.key not in current:
                verdict = ""
            else:
                verdict = "right" if r.correct else "not graded" if r.value is None else "wrong"
            score += r.points * max(0.0, 1.0 - self.online.penalty_per_attempt * ((number.get(e.key) or 1) - 1))
            left = max(0, self.online.attempts - used[e.key])
            rows.append(AnswerState(e.key, e.description, e.unit, e.sign_convention, e.points, precision(e), value,
                                    unit, used[e.key], left, verdict, refused[e.key]))
        reveal = self.reveal(now)
        # before a first answer there is nothing to explain (every row would read "not graded"), unless
        # the keys are shown after the due date
        feedback = self.course.feedback(grade, reveal) if current or reveal else ""
        return StudentPage(tuple(rows), grade, score, self.closed(now), reveal, feedback)

    def submit(self, student_id: str, form_id: str, typed: Mapping[str, tuple[str, str]], source: str,
               now: float | None = None) -> tuple[Receipt, StudentPage]:
        """Store a submission: each typed answer that is new (not blank, not the current answer) is one
        attempt, graded, or refused after the due date or beyond the attempts; all committed before return.

        A form id stored before (the same form sent again) stores nothing and returns the first receipt.
        The answers are graded outside the transaction that stores them; that transaction (under the
        student's lock) stores them only if the student's attempts are still those they were planned on,
        and else they are planned and graded again: the count of attempts is exact with any number of
        requests and server processes at once.
        """
        now = now or time.time()
        form_id = form_id[:64]
        while True:
            with self.database.reading() as conn:
                done = db.submission_by_form(conn, form_id)
                history = db.student_attempts(conn, student_id)
            if done is not None:
                return self._replayed(student_id, done, history, now)
            planned, current = self._plan(student_id, typed, history, now)
            grade = self.course.grade(student_id, current)
            results = {r.entry.key: r for r in grade.results}
            rows = []
            for key, value, unit, status, reason, number in planned:
                r = results[key] if status == "graded" else None
                rows.append({"answer_key": key, "value": value, "unit": unit, "status": status, "reason": reason,
                             "number": number, "correct": None if r is None else bool(r.correct),
                             "points": None if r is None else float(r.points)})
            seen = history[-1].id if history else None
            with self.database.writing(student_id) as conn:
                if db.submission_by_form(conn, form_id) is not None or db.last_attempt(conn, student_id) != seen:
                    continue  # sent twice at once, or another submission of theirs came first: look again
                sub_id = db.add_submission(conn, form_id, student_id, source, now, rows)
            break
        history = history + [db.Attempt(None, sub_id, student_id, r["answer_key"], r["value"], r["unit"], r["status"],
                                        r["reason"], r["number"], r["correct"], r["points"], now) for r in rows]
        outcomes = tuple(Outcome(k, s, why, n) for k, _v, _u, s, why, n in planned)
        return Receipt(sub_id, now, outcomes), self._page(student_id, history, now, grade)

    def _replayed(self, student_id: str, done: tuple[int, str], history: list[db.Attempt],
                  now: float) -> tuple[Receipt, StudentPage]:
        """The receipt of a form stored before, and the page as it is now."""
        if done[1] != student_id:
            raise GradekitError("expected a form of your own, got another's", field="form_id")
        mine = [a for a in history if a.submission_id == done[0]]
        at = mine[0].received_at if mine else now
        outcomes = tuple(Outcome(a.key, a.status, a.reason, a.number) for a in mine)
        return Receipt(done[0], at, outcomes, replayed=True), self._page(student_id, history, now)

    def _plan(self, student_id: str, typed: Mapping[str, tuple[str, str]], history: list[db.Attempt],
              now: float) -> tuple[list[tuple], dict[str, tuple[str, str]]]:
        """Each typed answer's fate as (key, value, unit, status, reason, attempt number), and the current
        answers with the graded ones among them."""
        closed = self.closed(now)
        current = current_answers(history).get(student_id, {})
        used = Counter(a.key for a in history if a.status == "graded")
        planned = []
        for e in self.course.entries(student_id):
            if e.key not in typed:
                continue
            value, unit = (x.strip()[:MAX_VALUE] for x in typed[e.key])
            if not value or current.get(e.key) == (value, unit):
                continue  # blank or unchanged: not an attempt
            if closed:
                planned.append((e.key, value, unit, "refused", "after the due date", None))
            elif used[e.key] >= self.online.attempts:
                planned.append((e.key, value, unit, "refused", f"all {self.online.attempts} attempts used", None))
            else:
                used[e.key] += 1
                current[e.key] = (value, unit)
                planned.append((e.key, value, unit, "graded", "", used[e.key]))
        return planned, current

    def read_upload(self, student_id: str, data: bytes,
                    filename: str) -> tuple[dict[str, tuple[str, str]], dict[str, str], list[str]]:
        """What an uploaded answers.csv holds for this student, ``{key: (value, unit)}`` as written, how each
        value is read (`Course.read_as`), and the reader's messages about the file (shown before it counts)."""
        sub = self.course.read_upload(student_id, data, filename)
        if sub is None:
            return {}, {}, [f"{filename}: expected rows for {student_id}, got none of yours"]
        own = {e.key for e in self.course.entries(student_id)}
        answers = {a.key: (a.raw, a.raw_unit) for a in sub.answers if a.key in own}
        return answers, self.course.read_as(student_id, answers), [str(i) for i in sub.issues]

    # --- the instructor --------------------------------------------------------------------------

    def dashboard(self) -> Dashboard:
        with self.database.reading() as conn:
            history = db.all_attempts(conn)
            count = db.count_submissions(conn)
            last = db.get_setting(conn, "last_export")
        board = Dashboard(submissions=count, last_export=json.loads(last) if last else None)
        board.problems = [it.label for it in self.course.assignment.items]
        by_student: dict[str, list[db.Attempt]] = {}
        for a in history:
            by_student.setdefault(a.student_id, []).append(a)
        items: dict[str, dict] = {}
        for s in self.course.students:
            if s.student_id not in self.course.by_id:
                continue
            mine = by_student.get(s.student_id, [])
            page = self._page(s.student_id, mine)
            per = {p.problem: p for p in page.grade.problems}
            board.students.append({
                "id": s.student_id, "name": s.display,
                "answered": sum(r.verdict != "" for r in page.rows),
                "right": sum(r.verdict == "right" for r in page.rows),
                "asked": len(page.rows), "attempts": sum(r.used for r in page.rows),
                "refused": sum(r.refused for r in page.rows), "score": page.score, "max": page.grade.max_points,
                "problems": [per[p].points if p in per else 0.0 for p in board.problems],
                "last": utc(mine[-1].received_at) if mine else "",
            })
            for r in page.rows:
                it = items.setdefault(r.key, {"key": r.key, "description": r.description, "answered": 0, "right": 0,
                                              "attempts": 0, "refused": 0, "students": 0})
                it["students"] += 1
                it["answered"] += r.verdict != ""
                it["right"] += r.verdict == "right"
                it["attempts"] += r.used
                it["refused"] += r.refused
        board.items = list(items.values())
        return board

    def export(self, out: Path) -> dict:
        """The class graded as ``gradekit grade`` grades the current answers (see `gradekit.web.grading.export`),
        plus ``attempts.csv`` (every attempt, refused ones too) and, with an attempt penalty, ``online.csv``;
        one export at a time per folder (a lock file). Returns a summary, also kept as the last export."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            with self.database.reading() as conn:
                history = db.all_attempts(conn)
            result = export(self.course, current_answers(history), out)
            write_csv(out / "attempts.csv",
                      ["student_id", "key", "value", "unit", "status", "reason", "attempt", "right", "points",
                       "submission", "received_utc"],
                      [[a.student_id, a.key, a.value, a.unit, a.status, a.reason, a.number or "",
                        "" if a.correct is None else ("yes" if a.correct else "no"),
                        "" if a.points is None else a.points,
                        a.submission_id, utc(a.received_at)] for a in history])
            if self.online.penalty_per_attempt:
                board = self.dashboard()
                write_csv(out / "online.csv", ["student_id", "name", "score with attempt penalty", "max"],
                          [[s["id"], s["name"], round(s["score"], 6), s["max"]] for s in board.students])
        summary = {"at": utc(time.time()), "graded": result.graded, "flags": [f.describe() for f in result.flags],
                   "folder": str(out)}
        with self.database.writing() as conn:
            db.put_setting(conn, "last_export", json.dumps(summary))
        return summary


def set_password(db_url: str | None, manifest: Path | None, password: str) -> None:
    """Store the instructor's password as an scrypt hash (the database is created or migrated first)."""
    database = db.Database(db.url_for(db_url, Path(manifest or ".")))
    try:
        database.migrate()
        with database.writing() as conn:
            db.put_setting(conn, "instructor_password", hash_password(password))
    finally:
        database.dispose()


def open_service(db_url: str | None, paths: Paths | None, *, manifest: Path | None = None,
                 create_secret: bool = False) -> Service:
    """The service of a database: *paths* are recorded in it (a new course or a changed one), or read
    from it when None (``gradekit export --db URL``).

    Raises:
        GradekitError: a database with no course recorded and no *paths* given.
    """
    url = db.url_for(db_url, Path(paths.manifest if paths else manifest or "."))
    database = db.Database(url)
    database.migrate()
    with database.writing() as conn:
        if paths is not None:
            db.put_setting(conn, "course", json.dumps(paths.__dict__))
        else:
            stored = db.get_setting(conn, "course")
            if stored is None:
                raise GradekitError("expected a database gradekit serve has used, got one without a course",
                                    path=db_url or url)
            paths = Paths(**json.loads(stored))
    return Service(paths, database, create_secret=create_secret)
