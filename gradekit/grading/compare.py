"""Compare what a student answered with their key: tolerance, units, points and diagnosis."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from operator import attrgetter

from gradekit.errors import GradekitError
from gradekit.grading.reader import Answer, Issue, Submission
from gradekit.keys import KeyEntry, Mistake
from gradekit.roster import Student
from gradekit.units import factor

_DEG = 180.0 / math.pi
_isfinite = math.isfinite

METHOD_MISTAKES = frozenset({"static-answer", "no-inertia-torque", "no-gravity"})
"""Catalogued mistakes of method, which feedback without ``--reveal`` may name.

Naming one tells a student what their method left out (the inertia, the inertia torque, gravity),
not their key: they still have to compute the part they left out. Every other catalogued mistake
(a sign flip, a ×1000 unit slip, degrees for radians, x and y swapped, the magnitude given for a
component) is a fixed transformation of the key, so naming it would hand the student the key.
"""


def generic_mistakes(entry: KeyEntry) -> tuple[Mistake, ...]:
    """Mistakes that need no re-solve: a sign flip, a ×1000 prefix slip, degrees for radians.

    The solver side may merge these with its own re-solved mistakes; the grader also falls back
    on them for any name the entry does not already carry.

    Args:
        entry: the key entry.

    Returns:
        ``sign flipped`` (−v, when v ≠ 0), ``×1000 unit slip`` and ``÷1000 unit slip`` (e.g.
        N·mm for N·m), and for angular units ``degrees for radians`` (v·180/π) or
        ``radians for degrees`` (v·π/180).
    """
    return tuple([Mistake(name, description, value) for name, description, value in _generic(entry)])


def _generic(entry: KeyEntry) -> list[tuple[str, str, float]]:
    """`generic_mistakes` as (name, description, value), without the records."""
    v = entry.value
    found = []
    if v != 0:
        convention = f" (convention: {entry.sign_convention})" if entry.sign_convention else ""
        found.append(("sign flipped", f"the sign is reversed{convention}", -v))
    found.append(("×1000 unit slip", "1000 times too large (e.g. N·mm for N·m)", v * 1000))
    found.append(("÷1000 unit slip", "1000 times too small (e.g. N·m for N·mm)", v / 1000))
    unit = entry.unit.replace(" ", "").lower()
    if unit.startswith("rad"):
        found.append(("degrees for radians", "given in degrees, asked in radians", v * _DEG))
    elif unit.startswith(("deg", "°")):
        found.append(("radians for degrees", "given in radians, asked in degrees", v / _DEG))
    return found


@dataclass(frozen=True)
class AnswerResult:
    """The verdict on one answer.

    ``value`` is the answer in the key's unit (None when missing or unreadable); ``rel_error``
    is |x − v| / |v| (None when v = 0 or no value); ``message`` says why an answer scored
    nothing without being wrong (missing, unreadable, wrong kind of unit). ``diagnosis`` is the
    first catalogued mistake that explains a wrong answer (for the instructor, and for feedback
    with ``--reveal``); ``method_diagnosis`` the first mistake of method (`METHOD_MISTAKES`) that
    does, the only one feedback without ``--reveal`` names. ``carried`` is the `gradekit.carry.Carried`
    a wrong answer matched when graded with carried-forward credit (its ``points`` are then the
    carried share).
    """

    entry: KeyEntry
    answer: Answer | None
    value: float | None
    correct: bool
    points: float
    rel_error: float | None
    abs_error: float | None
    diagnosis: Mistake | None = None
    message: str = ""
    error: float | None = None  # answer − key in the key's unit, wrapped at 360° for an angle
    method_diagnosis: Mistake | None = None
    carried: object | None = None  # gradekit.carry.Carried

    def __init__(
        self, entry: KeyEntry, answer: Answer | None, value: float | None, correct: bool, points: float,
        rel_error: float | None, abs_error: float | None, diagnosis: Mistake | None = None, message: str = "",
        error: float | None = None, method_diagnosis: Mistake | None = None, carried: object | None = None,
    ) -> None:
        # The fields, in order, written directly (as `Answer.__init__`: one verdict per answer of the class).
        fields = self.__dict__
        fields["entry"] = entry
        fields["answer"] = answer
        fields["value"] = value
        fields["correct"] = correct
        fields["points"] = points
        fields["rel_error"] = rel_error
        fields["abs_error"] = abs_error
        fields["diagnosis"] = diagnosis
        fields["message"] = message
        fields["error"] = error
        fields["method_diagnosis"] = method_diagnosis
        fields["carried"] = carried

    @property
    def angle(self) -> bool:
        """True for an angle: its error is in degrees (wrapped), never a percentage."""
        return is_angle(self.entry)


@dataclass(frozen=True)
class ProblemScore:
    """Points earned on one problem out of its maximum."""

    problem: str
    points: float
    max_points: float


class ResultColumns:
    """What the passes over a whole class (the report's item analysis, copy detection, the carried
    count) read of one grade's results, as columns, one item a result in order: ``keys`` (answer
    keys), ``values`` (None: no value), ``correct`` (verdicts), ``diagnoses`` (the name of each
    diagnosis, None: none) and ``carried`` (carried forward). Equal to another with the same columns.
    """

    _NAMES = ("keys", "values", "correct", "diagnoses", "carried")

    def __init__(
        self, keys: Sequence[str], values: Sequence[float | None], correct: Sequence[bool],
        diagnoses: Sequence[str | None], carried: Sequence[bool],
    ) -> None:
        self.keys, self.values, self.correct, self.diagnoses, self.carried = keys, values, correct, diagnoses, carried

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ResultColumns):
            return NotImplemented
        return all(list(getattr(self, n)) == list(getattr(other, n)) for n in self._NAMES)

    __hash__ = None  # (mutable lists)

    def __repr__(self) -> str:
        return f"ResultColumns({', '.join(f'{n}={getattr(self, n)!r}' for n in self._NAMES)})"


class _ColumnsOf(ResultColumns):
    """`ResultColumns` of built results, each column made as it is read (a pass reads each once; copy
    detection reads three)."""

    def __init__(self, results: Sequence[AnswerResult]) -> None:
        self._results = results

    keys = property(lambda self: list(map(_KEY_OF, self._results)))
    values = property(lambda self: list(map(_VALUE_OF, self._results)))
    correct = property(lambda self: list(map(_CORRECT_OF, self._results)))
    diagnoses = property(lambda self: [None if d is None else d.name for d in map(_DIAGNOSIS_OF, self._results)])
    carried = property(lambda self: [c is not None for c in map(_CARRIED_OF, self._results)])


_KEY_OF, _VALUE_OF, _CORRECT_OF = attrgetter("entry.key"), attrgetter("value"), attrgetter("correct")
_DIAGNOSIS_OF, _CARRIED_OF = attrgetter("diagnosis"), attrgetter("carried")


@dataclass(frozen=True)
class StudentGrade:
    """One student's graded submission (or the lack of one)."""

    student: Student
    submission: Submission | None
    results: tuple[AnswerResult, ...]
    problems: tuple[ProblemScore, ...]
    issues: tuple[Issue, ...]

    @property
    def total(self) -> float:
        """Points earned."""
        return sum(p.points for p in self.problems)

    @property
    def max_points(self) -> float:
        """Points available."""
        return sum(p.max_points for p in self.problems)

    @property
    def percent(self) -> float:
        """Total as a percentage of the maximum (0 when nothing was available)."""
        return 100.0 * self.total / self.max_points if self.max_points else 0.0

    def columns(self) -> ResultColumns:
        """The results as columns (`ResultColumns`): what a pass over the class reads. A grade a helper
        process sent (`gradekit.grading.parallel.PackedGrade`) has them without building its results."""
        return _ColumnsOf(self.results)


_DEGREES = ("deg", "degree", "degrees", "°")
_RADIANS = ("rad", "radian", "radians")


@lru_cache(maxsize=1024)
def _turn(unit: str) -> float:
    """A full turn in *unit* (360 for degrees, 2π for radians), 0 for a unit that is not an angle."""
    unit = unit.replace(" ", "").lower()
    return 360.0 if unit in _DEGREES else 2 * math.pi if unit in _RADIANS else 0.0


def is_angle(entry: KeyEntry) -> bool:
    """An answer in degrees or radians, or one whose tolerance wraps."""
    return bool(entry.tolerance.period) or bool(_turn(entry.unit))


def diagnose(entry: KeyEntry, value: float, *, method_only: bool = False) -> Mistake | None:
    """The first catalogued mistake whose value the entry's tolerance accepts *value* around.

    The entry's own (re-solved) mistakes come first, then `generic_mistakes` not already named;
    with *method_only*, only the mistakes of method (`METHOD_MISTAKES`).
    """
    return _diagnoses(entry, value)[1 if method_only else 0]


def _diagnoses(entry: KeyEntry, value: float) -> tuple[Mistake | None, Mistake | None]:
    """(`diagnose`, `diagnose` with *method_only*) in one pass over the candidates.

    The generic mistakes are made only when no mistake of the entry's own explains *value* (none
    of them is a mistake of method).
    """
    if not _isfinite(value):  # accepted around nothing
        return None, None
    tol = entry.tolerance
    if tol.mode == "relative" and not tol.period:
        rel, floor = tol.rel, tol.abs

        def accepts(answer: float, key: float) -> bool:  # tol.accepts(answer, key), the same operations
            return abs(answer - key) <= max(rel * abs(key), floor) * (1 + 1e-12)
    else:
        accepts = tol.accepts
    first = None
    for mistake in entry.mistakes:
        if _isfinite(mistake.value) and accepts(value, mistake.value):
            if first is None:
                first = mistake
            if mistake.name in METHOD_MISTAKES:
                return first, mistake
    if first is not None:
        return first, None
    named = {m.name for m in entry.mistakes}
    for name, description, mistaken in _generic(entry):  # the record made for the one that fits only
        if name not in named and _isfinite(mistaken) and accepts(value, mistaken):
            return Mistake(name, description, mistaken), None
    return None, None


def compare(entry: KeyEntry, answer: Answer | None) -> AnswerResult:
    """Grade one answer against its key entry.

    The answer is converted to the key's unit (a missing unit means the key's unit), accepted
    by ``entry.tolerance.accepts``, and when wrong, diagnosed with `diagnose`.

    Args:
        entry: the key entry.
        answer: what the student wrote for that key, or None.

    Returns:
        The verdict.
    """
    if answer is None:
        return AnswerResult(entry, None, None, False, 0.0, None, None, message="no answer given")
    if answer.number is None:
        return AnswerResult(entry, answer, None, False, 0.0, None, None, message=answer.issue)
    value = answer.number
    if answer.unit and answer.unit != entry.unit:
        try:
            value = answer.number * factor(answer.unit, entry.unit)
        except GradekitError as exc:
            return AnswerResult(entry, answer, None, False, 0.0, None, None, message=exc.detail)
    tol = entry.tolerance
    key = entry.value
    error = value - key  # tol.accepts(value, key), with its difference kept (the same operations)
    if tol.period:
        error = (error + tol.period / 2) % tol.period - tol.period / 2
    if _isfinite(value) and _isfinite(key):
        if tol.mode == "relative":  # tol.band(key), the same operations
            band = tol.rel * abs(key)
            if tol.abs > band:
                band = tol.abs
        else:
            band = tol.band(key)
        correct = abs(error) <= band * (1 + 1e-12)
    else:
        correct = False
    turn = 0.0 if tol.period else _turn(entry.unit)
    if turn:
        error = (error + turn / 2) % turn - turn / 2
    abs_error = abs(error)
    rel_error = abs_error / abs(entry.value) if entry.value and not (tol.period or turn) else None
    if correct:
        return AnswerResult(entry, answer, value, True, entry.points, rel_error, abs_error, None, "", error, None)
    diagnosis, method = _diagnoses(entry, value)
    return AnswerResult(entry, answer, value, False, 0.0, rel_error, abs_error, diagnosis, "", error, method)


def grade_student(
    student: Student, entries: Sequence[KeyEntry], submission: Submission | None
) -> StudentGrade:
    """Grade one student's submission against their key entries.

    Partial credit per problem is the sum of the points of the correct answers. Answers to keys
    the student's key lacks, and keys left unanswered, become issues naming the file.

    Args:
        student: the student.
        entries: the student's key entries.
        submission: their submission, or None when there is none.

    Returns:
        The grade with one result per key entry, in key order.
    """
    answers = {a.key: a for a in submission.answers} if submission else {}
    issues = list(submission.issues) if submission else []
    results = []
    missing: list[str] = []
    unread: dict[tuple, list[int | None]] = {}  # (field, message) -> lines, so one cause is one message
    for entry in entries:
        result = compare(entry, answers.get(entry.key))
        results.append(result)
        if submission is None or not submission.readable:
            continue
        answer = result.answer
        if answer is None:
            missing.append(entry.key)
        elif result.value is None:
            unread.setdefault((answer.field, result.message), []).append(answer.line)
    if submission is not None and submission.readable:
        for (fld, message), lines in unread.items():
            if len(lines) > 1:
                shown = sorted(x for x in lines if x is not None)
                where = f" (lines {shown[0]}–{shown[-1]})" if shown else ""
                message = f"{message}, in {len(lines)} rows{where}"
            issues.append(Issue(submission.path, lines[0] if len(lines) == 1 else None, fld, message))
        if len(missing) == 1:
            issues.append(Issue(submission.path, None, "key", f"expected an answer for {missing[0]!r}, got none"))
        elif missing:
            listed = ", ".join(missing[:5]) + (", …" if len(missing) > 5 else "")
            issues.append(Issue(submission.path, None, "key",
                                f"expected answers for {len(missing)} keys ({listed}), got none"))
    if submission is not None:
        own = {e.key for e in entries}
        for answer in submission.answers:
            if answer.key not in own:
                issues.append(
                    Issue(
                        submission.path,
                        answer.line,
                        "key",
                        f"expected one of your keys, got {answer.key!r} (not in your assignment)",
                    )
                )
    scores = problem_scores(results)
    return StudentGrade(student, submission, tuple(results), scores, tuple(issues))


def problem_scores(results: Sequence[AnswerResult]) -> tuple[ProblemScore, ...]:
    """Points earned and available per problem (in the order the problems first appear): the sum of
    the points of its answers' verdicts."""
    problems: dict[str, list[float]] = {}
    for result in results:
        earned_max = problems.setdefault(result.entry.problem, [0.0, 0.0])
        earned_max[0] += result.points
        earned_max[1] += result.entry.points
    return tuple(ProblemScore(p, pts, mx) for p, (pts, mx) in problems.items())
