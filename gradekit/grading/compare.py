"""Compare what a student answered with their key: tolerance, units, points and diagnosis."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from gradekit.errors import GradekitError
from gradekit.grading.reader import Answer, Issue, Submission
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Mistake, PartialCredit, half_widths, tolerance_columns, within, wrapped
from gradekit.units import factor, is_angular

_DEG = 180.0 / math.pi

HAND_CHECK = "checked by hand by your instructor"
"""The message of an answer the bank marks for hand checking (`KeyEntry.hand_check`)."""

METHOD_MISTAKES = frozenset({"static-answer", "no-inertia-torque", "no-gravity"})
"""Catalogued mistakes of method, which feedback without ``--reveal`` may name.

Naming one tells a student what their method left out (the inertia, the inertia torque, gravity),
not their key: they still have to compute the part they left out. Every other catalogued mistake
(a sign flip, a ×1000 unit slip, degrees for radians, x and y swapped, the magnitude given for a
component) is a fixed transformation of the key, so naming it would hand the student the key.
"""


class _Generic(NamedTuple):
    """One kind of mistake that needs no re-solve: made from the key's value v alone."""

    name: str
    description: str  # "{convention}" stands for the entry's sign convention, when it states one
    made: Callable  # the mistaken value from v (a float, or an array of them)
    units: tuple[str, ...] = ()  # only for a unit starting with one of these (spaces removed, lower case); (): any
    nonzero: bool = False  # only where v ≠ 0
    prefixed: bool = False  # only for a unit with an SI prefix to slip: no angle nor angle per time (`is_angular`)


_GENERIC = (
    _Generic("sign flipped", "the sign is reversed{convention}", lambda v: -v, nonzero=True),
    _Generic("×1000 unit slip", "1000 times too large (e.g. N·mm for N·m)", lambda v: v * 1000, prefixed=True),
    _Generic("÷1000 unit slip", "1000 times too small (e.g. N·m for N·mm)", lambda v: v / 1000, prefixed=True),
    _Generic("degrees for radians", "given in degrees, asked in radians", lambda v: v * _DEG, ("rad",)),
    _Generic("radians for degrees", "given in radians, asked in degrees", lambda v: v / _DEG, ("deg", "°")),
)
"""The generic mistakes, in the order `generic_mistakes` lists them (an earlier one wins a tie)."""

_GENERIC_INDEX = {g.name: j for j, g in enumerate(_GENERIC)}


def _generic_columns(keys: np.ndarray, units: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """The `_GENERIC` mistakes of many key values (*keys*, each in its unit of *units*) as (keys ×
    kinds) columns: each mistaken value, and where the kind applies."""
    index = {u: i for i, u in enumerate(dict.fromkeys(units))}  # each distinct unit decided once
    by_unit = np.array([[(not g.units or u.replace(" ", "").lower().startswith(g.units))
                         and not (g.prefixed and is_angular(u)) for g in _GENERIC] for u in index], bool)
    applies = by_unit[[index[u] for u in units]] & (~np.array([g.nonzero for g in _GENERIC]) | (keys != 0)[:, None])
    with np.errstate(over="ignore", invalid="ignore"):
        made = np.stack([g.made(keys) for g in _GENERIC], axis=1)
    return made, applies


def _generic(kind: _Generic, entry: KeyEntry, value: float) -> Mistake:
    """The *kind* of generic mistake made on *entry*'s key, leading to *value*."""
    convention = f" (convention: {entry.sign_convention})" if entry.sign_convention else ""
    return Mistake(kind.name, kind.description.format(convention=convention), value)


def generic_mistakes(entry: KeyEntry) -> tuple[Mistake, ...]:
    """Mistakes that need no re-solve: a sign flip, a ×1000 prefix slip, degrees for radians.

    The solver side may merge these with its own re-solved mistakes; the grader also falls back
    on them for any name the entry does not already carry.

    Args:
        entry: the key entry.

    Returns:
        ``sign flipped`` (−v, when v ≠ 0), ``×1000 unit slip`` and ``÷1000 unit slip`` (e.g.
        N·mm for N·m; not for an angle or an angle per time, which have no prefix to slip:
        `gradekit.units.is_angular`), and for angular units ``degrees for radians`` (v·180/π) or
        ``radians for degrees`` (v·π/180).
    """
    made, applies = _generic_columns(np.array([entry.value], float), [entry.unit])
    return tuple(_generic(g, entry, x) for g, x, ok in zip(_GENERIC, made[0].tolist(), applies[0].tolist(), strict=True)
                 if ok)


class AnswerResult(NamedTuple):
    """The verdict on one answer.

    ``value`` is the answer in the key's unit (None when missing or unreadable); ``rel_error``
    is |x − v| / |v| (None when v = 0, for an angle, or with no value); ``message`` says why an
    answer scored nothing without being wrong (missing, unreadable, wrong kind of unit).
    ``diagnosis`` is the catalogued mistake that explains a wrong answer best (for the instructor,
    and for feedback with ``--reveal``); ``method_diagnosis`` is that mistake when it is one of
    method (`METHOD_MISTAKES`), the only kind feedback without ``--reveal`` names. ``carried`` is the
    `gradekit.solving.carry.Carried` a wrong answer matched when graded with carried-forward credit (its
    ``points`` are then the carried share). ``partial``: not correct, but within the wider band of the
    assignment's partial credit (`gradekit.solving.keys.PartialCredit`), its ``points`` that share.
    ``pending``: an answer the bank marks for checking by hand (`KeyEntry.hand_check`) whose points the
    instructor has not given yet; it counts neither in the score nor in the maximum. Once given (`grade_class`'s
    *hand*), its ``points`` are those the instructor gave.
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
    error: float | None = None  # answer − key in the key's unit, wrapped at a full turn for an angle
    method_diagnosis: Mistake | None = None
    carried: object | None = None  # gradekit.solving.carry.Carried
    band: float | None = None  # the half-width of the acceptance band around the key, in the key's unit
    partial: bool = False  # outside the band, within the assignment's wider band of partial credit
    pending: bool = False  # checked by hand, its points not given yet

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


@dataclass(frozen=True)
class ResultColumns:
    """What the passes over a whole class (the report's item analysis, copy detection, the carried
    count) read of one grade's results, as columns, one item a result in order: ``keys`` (answer
    keys), ``values`` (None: no value), ``correct`` (verdicts), ``diagnoses`` (the name of each
    diagnosis, None: none) and ``carried`` (carried forward)."""

    keys: list[str]
    values: list[float | None]
    correct: list[bool]
    diagnoses: list[str | None]
    carried: list[bool]


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
        """The results as columns (`ResultColumns`): what a pass over the class reads."""
        r = self.results
        return ResultColumns(
            [x.entry.key for x in r], [x.value for x in r], [x.correct for x in r],
            [None if x.diagnosis is None else x.diagnosis.name for x in r], [x.carried is not None for x in r],
        )


_DEGREES = ("deg", "degree", "degrees", "°")
_RADIANS = ("rad", "radian", "radians")


def _turn(unit: str) -> float:
    """A full turn in *unit* (360 for degrees, 2π for radians), 0 for a unit that is not an angle."""
    unit = unit.replace(" ", "").lower()
    return 360.0 if unit in _DEGREES else 2 * math.pi if unit in _RADIANS else 0.0


def is_angle(entry: KeyEntry) -> bool:
    """An answer in degrees or radians, or one whose tolerance wraps."""
    return bool(entry.tolerance.period) or bool(_turn(entry.unit))


class _Cells:
    """The cells of a class being graded, as columns (one item a key entry of a student): each
    entry, what was answered for it, the answer in the key's unit (NaN: none) and why there is none."""

    def __init__(self) -> None:
        self.entries: list[KeyEntry] = []
        self.answers: list[Answer | None] = []
        self.values: list[float] = []
        self.messages: list[str] = []
        self._factors: dict[tuple[str, str], float | str] = {}

    def add(self, entry: KeyEntry, answer: Answer | None) -> None:
        self.entries.append(entry)
        self.answers.append(answer)
        value, message = math.nan, ""
        if answer is None:
            message = "no answer given"
        elif answer.number is None:
            message = answer.issue
        elif answer.unit and answer.unit != entry.unit:
            f = self._factor(answer.unit, entry.unit)
            if isinstance(f, str):
                message = f
            else:
                value = answer.number * f
        else:
            value = answer.number
        self.values.append(value)
        self.messages.append(message)

    def _factor(self, unit: str, to: str) -> float | str:
        """The unit's factor to the key's unit, or the message why there is none (each pair once a class)."""
        got = self._factors.get((unit, to))
        if got is None:
            try:
                got = factor(unit, to)
            except GradekitError as exc:
                got = exc.detail
            self._factors[unit, to] = got
        return got


def _tolerances(entries: Sequence[KeyEntry]) -> tuple[np.ndarray, ...]:
    return tolerance_columns([e.tolerance for e in entries])


def _diagnoses(
    entries: Sequence[KeyEntry], values: np.ndarray, tolerances: tuple[np.ndarray, ...]
) -> list[Mistake | None]:
    """For each wrong answer (*values* in its entry's unit), the catalogued mistake that explains it:
    of the entry's own (re-solved) mistakes and the `generic_mistakes` it does not already name, those
    whose band accepts the answer, the closest (in bands, the difference wrapped at a full turn as the band
    wraps it; an earlier one on a tie). The closest, not the first: a ×1000 unit slip of a torque can also
    fall inside a wide band around its static answer.

    The candidates are a (cells × candidates) array, each row the entry's own mistakes, NaN up to the
    most any entry has, then the generic ones (NaN where one does not apply): a `Mistake` is made only
    for a generic winner."""
    n = len(entries)
    if not n:
        return []
    own = [e.mistakes for e in entries]
    counts = np.array([len(m) for m in own], int)
    flat = [m for ms in own for m in ms]
    rows = np.repeat(np.arange(n), counts)
    width = int(counts.max())
    candidates = np.full((n, width + len(_GENERIC)), np.nan)
    candidates[rows, np.arange(len(flat)) - np.repeat(np.cumsum(counts) - counts, counts)] = [m.value for m in flat]
    generic, applies = _generic_columns(np.array([e.value for e in entries], float), [e.unit for e in entries])
    for i, m in zip(rows.tolist(), flat, strict=True):  # a name the entry carries is its own, not the generic one
        if m.name in _GENERIC_INDEX:
            applies[i, _GENERIC_INDEX[m.name]] = False
    candidates[:, width:] = np.where(applies, generic, np.nan)
    x = values[:, None]
    rel, abs_, sig, period = (t[:, None] for t in tolerances)
    fits = within(x, candidates, rel, abs_, sig, period)
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = np.abs(wrapped(x - candidates, period)) / half_widths(candidates, rel, abs_, sig)
    distance = np.where(fits, np.where(np.isfinite(distance), distance, 0.0), np.inf)
    best = distance.argmin(axis=1)  # the first of the closest: the earlier candidate on a tie
    found: list[Mistake | None] = [None] * n
    for i in np.flatnonzero(fits.any(axis=1)).tolist():
        j = int(best[i])
        found[i] = own[i][j] if j < width else _generic(_GENERIC[j - width], entries[i], float(candidates[i, j]))
    return found


def _results(cells: _Cells, partial: Mapping[str, PartialCredit],
             hand: Mapping[tuple[str, str], float]) -> list[AnswerResult]:
    """Every cell's verdict: one comparison for all of them through the one band rule (`within`), and
    one for the wider band of partial credit where the assignment gives it; the catalogued mistakes
    looked for only where the answer is not right. An answer checked by hand is never judged: its points
    are the instructor's from *hand* (by student and key), and until given it is ``pending``."""
    entries = cells.entries
    values = np.array(cells.values, float)
    keys = np.array([e.value for e in entries], float)
    tolerances = _tolerances(entries)
    rel, abs_, sig, period = tolerances
    by_hand = [e.hand_check for e in entries]
    correct = (within(values, keys, rel, abs_, sig, period) & ~np.array(by_hand, bool)).tolist()
    share = [0.0] * len(entries)
    if partial:
        rules = [partial.get(e.problem) for e in entries]
        widen = np.array([r.within if r else 1.0 for r in rules], float)
        near = within(values, keys, rel, abs_, sig, period, widen).tolist()
        share = [r.credit if r and n and not ok else 0.0 for r, n, ok in zip(rules, near, correct, strict=True)]
    bands = half_widths(keys, rel, abs_, sig).tolist()
    turns = {unit: _turn(unit) for unit in {e.unit for e in entries}}
    turn = np.array([0.0 if e.tolerance.period else turns[e.unit] for e in entries], float)
    error = wrapped(wrapped(values - keys, period), turn)
    with np.errstate(divide="ignore", invalid="ignore"):  # |x − v| / |v|: a share only for a value v ≠ 0, no angle
        relative = np.where((keys != 0) & (period == 0) & (turn == 0), np.abs(error) / np.abs(keys), np.nan).tolist()
    wrong = [i for i, ok in enumerate(correct) if not ok and not by_hand[i] and math.isfinite(cells.values[i])]
    at_wrong = tuple(t[wrong] for t in tolerances)
    diagnosed = dict(zip(wrong, _diagnoses([entries[i] for i in wrong], values[wrong], at_wrong), strict=True))
    out = []
    for i, (e, answer, value, err, rel_error) in enumerate(
        zip(entries, cells.answers, cells.values, error.tolist(), relative, strict=True)
    ):
        if by_hand[i]:  # read and shown, never judged: the instructor checks it
            given = hand.get((e.student_id, e.key))
            out.append(AnswerResult(e, answer, None if value != value else value, False, given or 0.0, None, None,
                                    message=cells.messages[i] or HAND_CHECK, band=bands[i], pending=given is None))
            continue
        if value != value:  # NaN: no value to compare
            out.append(AnswerResult(e, answer, None, False, 0.0, None, None, message=cells.messages[i], band=bands[i]))
            continue
        if rel_error != rel_error:
            rel_error = None
        if correct[i]:
            out.append(AnswerResult(e, answer, value, True, e.points, rel_error, abs(err), None, "", err,
                                    band=bands[i]))
            continue
        d = diagnosed.get(i)
        method = d if d is not None and d.name in METHOD_MISTAKES else None
        out.append(AnswerResult(e, answer, value, False, e.points * share[i], rel_error, abs(err), d, "", err, method,
                                band=bands[i], partial=share[i] > 0))
    return out


def diagnose(entry: KeyEntry, value: float, *, method_only: bool = False) -> Mistake | None:
    """The catalogued mistake that explains *value* (an answer in the entry's unit) best, or None;
    with *method_only*, only when that mistake is one of method (`METHOD_MISTAKES`)."""
    found = _diagnoses([entry], np.array([value], float), _tolerances([entry]))[0]
    if method_only and (found is None or found.name not in METHOD_MISTAKES):
        return None
    return found


def compare(entry: KeyEntry, answer: Answer | None) -> AnswerResult:
    """Grade one answer against its key entry (`grade_class` for one cell).

    The answer is converted to the key's unit (a missing unit means the key's unit), accepted
    within the entry's tolerance band, and when wrong, diagnosed with `diagnose`.
    """
    cells = _Cells()
    cells.add(entry, answer)
    return _results(cells, {}, {})[0]


def grade_class(
    students: Sequence[Student], entries: Mapping[str, Sequence[KeyEntry]], chosen: Mapping[str, Submission | None],
    partial: Mapping[str, PartialCredit] | None = None, hand: Mapping[tuple[str, str], float] | None = None,
) -> list[StudentGrade]:
    """Grade every student (in order) against their own key entries: every answer of the class is
    converted to its key's unit and compared in one pass (`_results`), then each student's grade is
    put together with the issues of their submission.

    A problem's points are the sum of its answers' points: an answer's all when right, its
    *partial* credit (per problem label, `PartialCredit`) when within that wider band, else none; an
    answer checked by hand, the points the instructor gave it in *hand* (by student id and key; see
    `gradekit.grading.hand`), and until then it counts neither in the points nor in the maximum.
    Answers to keys the student's key lacks, and keys left unanswered, become issues naming the file.
    """
    cells = _Cells()
    spans = []
    for s in students:
        submission = chosen.get(s.student_id)
        answers = {a.key: a for a in submission.answers} if submission else {}
        start = len(cells.entries)
        for entry in entries.get(s.student_id, ()):
            cells.add(entry, answers.get(entry.key))
        spans.append((start, len(cells.entries)))
    results = _results(cells, partial or {}, hand or {})
    return [_grade(s, chosen.get(s.student_id), results[a:b], entries.get(s.student_id, ()))
            for s, (a, b) in zip(students, spans, strict=True)]


def grade_student(
    student: Student, entries: Sequence[KeyEntry], submission: Submission | None,
    partial: Mapping[str, PartialCredit] | None = None,
) -> StudentGrade:
    """Grade one student's submission against their key entries (`grade_class` for one student)."""
    return grade_class([student], {student.student_id: entries}, {student.student_id: submission}, partial)[0]


def _grade(student: Student, submission: Submission | None, results: list[AnswerResult],
           entries: Sequence[KeyEntry]) -> StudentGrade:
    """One student's grade from their verdicts, with their submission's issues."""
    issues = list(submission.issues) if submission else []
    if submission is not None and submission.readable:
        missing: list[str] = []
        unread: dict[tuple, list[int | None]] = {}  # (field, message) -> lines, so one cause is one message
        for result in results:
            answer = result.answer
            if answer is None:
                missing.append(result.entry.key)
            elif result.value is None:
                unread.setdefault((answer.field, result.message), []).append(answer.line)
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
                issues.append(Issue(submission.path, answer.line, "key",
                                    f"expected one of your keys, got {answer.key!r} (not in your assignment)"))
    return StudentGrade(student, submission, tuple(results), problem_scores(results), tuple(issues))


def problem_scores(results: Sequence[AnswerResult]) -> tuple[ProblemScore, ...]:
    """Points earned and available per problem (in the order the problems first appear): the sum of
    the points of its answers' verdicts; an answer checked by hand counts in neither until the
    instructor gives its points (``pending``)."""
    problems: dict[str, list[float]] = {}
    for result in results:
        earned_max = problems.setdefault(result.entry.problem, [0.0, 0.0])
        if result.pending:
            continue
        earned_max[0] += result.points
        earned_max[1] += result.entry.points
    return tuple(ProblemScore(p, pts, mx) for p, (pts, mx) in problems.items())
