"""A grade handed back by the helper process (`pack`/`unpack`): unanswered keys, unreadable cells,
unit conversions, diagnoses and carried credit come back equal when graded again; a grade for other
entries is refused."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gradekit.grading.compare import grade_student
from gradekit.grading.parallel import PackedGrade, pack, unpack
from gradekit.grading.reader import Answer, Issue, Submission
from gradekit.keys import KeyEntry, Mistake, Tolerance
from gradekit.roster import Student

TOL = Tolerance("relative", 0.01, abs=0.5)
STUDENT = Student("1001", "A B")
ENTRIES = [
    KeyEntry("1001", "p1", "p1.T", 12.5, "N*m", TOL, 2, mistakes=(Mistake("static-answer", "static", 10.0),)),
    KeyEntry("1001", "p1", "p1.F", -3.0, "N", TOL, 1.5),
    KeyEntry("1001", "p2", "p2.a", 7.0, "m/s^2", TOL, 1),
    KeyEntry("1001", "p2", "p2.th", 359.0, "deg", Tolerance("relative", 0.0, abs=1.0, period=360.0), 1),
]


def _grade():
    answers = (
        Answer("p1.T", "10.1", "", 10.1, "", 2),  # wrong: the static answer
        Answer("p1.F", "-3000", "N*mm", -3000.0, "N*mm", 3, "unit"),  # N·mm is no force: not graded
        Answer("p2.th", "-0.5", "deg", -0.5, "deg", 4, "unit"),  # right, wrapped
        Answer("p9.x", "abc", "", None, "", 5, "value", "expected a number, got 'abc'"),
    )
    sub = Submission("1001.csv", "1001", answers, (Issue("1001.csv", 5, "value", "bad"),), named="1001")
    return grade_student(STUDENT, ENTRIES, sub)


def test_a_grade_with_every_kind_of_result_comes_back_equal():
    grade = _grade()
    assert [r.correct for r in grade.results] == [False, False, False, True]
    assert grade.results[1].value is None and "same kind" in grade.results[1].message
    assert grade.results[0].diagnosis == Mistake("static-answer", "static", 10.0)
    assert grade.results[2].answer is None and grade.results[2].message == "no answer given"
    back = unpack(pack(grade), STUDENT, ENTRIES)
    assert back == grade
    assert back.results[2].answer is None and back.results[0].answer is back.submission.answers[0]
    assert [r.points for r in back.results] == [0.0, 0.0, 0.0, 1]
    assert math.isclose(back.total, 1.0) and back.issues == grade.issues


def _carry(grade):
    """*grade* with carried credit on its first answer (as `CarryForward.apply` gives it)."""
    results = list(grade.results)
    results[0] = replace(results[0], points=1.0, carried=("p1.T", 0.5))
    return replace(grade, results=tuple(results))


def test_carried_credit_comes_back_with_its_points_when_graded_again_with_it():
    grade = _carry(_grade())
    data = pack(grade)
    back = PackedGrade(data, STUDENT, lambda sub: _carry(grade_student(STUDENT, ENTRIES, sub))).built()
    assert back == grade and back.results[0].points == 1.0 and back.results[0].carried == ("p1.T", 0.5)
    with pytest.raises(ValueError, match="expected 1001's submission to grade as the helper process graded it"):
        unpack(data, STUDENT, ENTRIES)  # graded again without the carried credit


def test_a_grade_unpacked_for_other_entries_is_refused():
    with pytest.raises(ValueError, match="expected 1001's submission to grade as the helper process graded it"):
        unpack(pack(_grade()), STUDENT, ENTRIES[:3])


@pytest.mark.parametrize(
    "values",
    [
        [],
        [1.5, -0.0, math.inf],
        [None, 2.0, None, -math.inf, None],
        [None],
        [3.0, None],
    ],
)
def test_optional_floats_come_back_exactly_with_their_nones(values):
    from gradekit.grading.parallel import _floats, _unfloats

    back = _unfloats(*_floats(values))
    assert [v is None for v in back] == [v is None for v in values]
    assert back == values
    assert [math.copysign(1.0, v) for v in back if v is not None] == [
        math.copysign(1.0, v) for v in values if v is not None
    ]  # -0.0 keeps its sign


def test_optional_floats_with_flags_of_another_length_are_refused():
    from array import array

    from gradekit.grading.parallel import _unfloats

    with pytest.raises(ValueError, match="expected 2 flags of None, got 3"):
        _unfloats(array("d", [1.0, 2.0]).tobytes(), bytes([0, 1, 0]))
    assert _unfloats(array("d", [1.0, 2.0]).tobytes(), bytes([1, 0])) == [None, 2.0]
