"""A helper's grade as the parent keeps it (`PackedGrade`): its columns read from the packed data, its
results built only when read and equal to `unpack`'s; malformed data refused; `Grades` builds the
helper's grades on first access and equals the tuple of the same grades."""

from __future__ import annotations

import copy
import pickle
from dataclasses import replace

import pytest

from gradekit.grading.batch import Grades
from gradekit.grading.compare import StudentGrade, grade_student
from gradekit.grading.parallel import PackedGrade, pack
from gradekit.grading.reader import Submission
from gradekit.roster import Student
from tests.test_grading_pack import ENTRIES, STUDENT, _carry, _grade


def _carried():
    return _carry(_grade())


def _packed(grade: StudentGrade, asked: list | None = None, entries=ENTRIES) -> PackedGrade:
    def regrade(sub):
        if asked is not None:
            asked.append(1)
        again = grade_student(STUDENT, entries, sub)
        return _carry(again) if any(r.carried for r in grade.results) else again

    return PackedGrade(pack(grade), STUDENT, regrade)


@pytest.mark.parametrize("make", [_grade, _carried])
def test_a_packed_grade_reads_its_columns_without_its_entries_and_builds_the_same_grade(make):
    grade = make()
    asked: list = []
    packed = _packed(grade, asked)
    assert packed.columns() == grade.columns()
    assert (packed.student, packed.problems, packed.issues) == (grade.student, grade.problems, grade.issues)
    assert (packed.total, packed.percent) == (grade.total, grade.percent)
    sub = packed.submission
    assert (sub.path, sub.readable, sub.issues, sub.conflicts, sub.by_name) == (
        grade.submission.path, True, grade.submission.issues, (), True)
    assert "answers" not in vars(sub) and asked == []  # nothing so far needed the answers or the key entries
    assert sub.built() == grade.submission and type(sub.built()) is Submission
    assert packed.results == grade.results and asked == [1]
    packed.results  # noqa: B018 (built once)
    assert asked == [1]
    built = packed.built()
    assert type(built) is StudentGrade and built == grade
    assert built.results[0].answer is built.submission.answers[0]


def test_the_columns_of_a_grade():
    c = _carried().columns()
    assert c.keys == ["p1.T", "p1.F", "p2.a", "p2.th"]
    assert c.values[1:3] == [None, None] and c.values[3] == pytest.approx(-0.5)
    assert c.correct == [False, False, False, True]
    assert c.diagnoses == ["static-answer", None, None, None]
    assert c.carried == [True, False, False, False]


def test_a_packed_grade_copies_and_pickles_as_a_plain_grade():
    grade = _grade()
    for other in (pickle.loads(pickle.dumps(_packed(grade))), copy.copy(_packed(grade))):
        assert type(other) is StudentGrade and other == grade


def test_a_packed_grade_without_a_submission_or_answers_is_refused_or_kept():
    with pytest.raises(ValueError, match="expected a graded submission"):
        pack(grade_student(STUDENT, ENTRIES, None))
    empty = grade_student(STUDENT, [], Submission("1001.csv", "1001", named="1001"))
    back = PackedGrade(pack(empty), STUDENT, lambda sub: grade_student(STUDENT, [], sub))
    assert back.columns() == empty.columns() and back.built() == empty


def _broken(data: tuple, at: int, value) -> tuple:
    return (*data[:at], value, *data[at + 1 :])


@pytest.mark.parametrize(
    ("at", "value", "message"),
    [
        (8, "p1.T\x00p1.F\x00p2.a", "got 3 keys"),  # a key missing
        (9, bytes([0, 0, 2, 1]), "verdicts \\(0 or 1\\)"),  # a verdict neither right nor wrong
        (9, bytes([0, 0, 1]), "expected 3 keys"),  # a verdict missing
        (10, (b"\x00" * 8, b""), "got 4 keys and 1 values"),  # a value missing
        (11, [(9, "x")], "malformed"),  # a diagnosis of no result
        (12, [9], "malformed"),  # carried credit on no result
        (4, 9, "expected 9 answers"),  # more answers than texts
        (7, b"\x00" * 8, "expected 4 answers"),  # a line number missing
        (3, ((1, 2),), "malformed"),  # a problem score without its maximum
        (0, ("1001.csv", "1001"), "malformed"),  # a submission's head cut short
    ],
)
def test_a_malformed_packed_grade_is_refused(at, value, message):
    data = pack(_grade())
    with pytest.raises(ValueError, match=f"expected a grade packed for 1001.*{message}"):
        PackedGrade(_broken(data, at, value), STUDENT, lambda: ENTRIES)


@pytest.mark.parametrize(
    "entries",
    [
        [replace(e, key=e.key + "x") if i == 1 else e for i, e in enumerate(ENTRIES)],  # another key
        [replace(e, value=e.value + 10) if i == 3 else e for i, e in enumerate(ENTRIES)],  # a right answer wrong
        ENTRIES[:3],
    ],
)
def test_a_packed_grade_graded_again_otherwise_is_refused(entries):
    packed = _packed(_grade(), entries=entries)
    assert packed.columns() == _grade().columns()
    with pytest.raises(ValueError, match="expected 1001's submission to grade as the helper process graded it"):
        packed.results  # noqa: B018


def test_grades_build_a_helpers_grades_on_first_access_and_equal_the_tuple():
    plain = grade_student(Student("1000", "Z Z"), [], None)
    grade = _grade()
    asked: list = []
    grades = Grades([plain, _packed(grade, asked)])
    assert len(grades) == 2 and asked == []
    assert grades.as_made()[1].columns() == grade.columns() and asked == []
    assert grades == (plain, grade) and (plain, grade) == grades and asked == [1]
    assert all(type(g) is StudentGrade for g in grades) and grades[-1] is grades[1]
    assert grades[:1] == (plain,) and list(grades) == [plain, grade]
    assert grades == Grades([plain, grade]) and hash(grades) == hash((plain, grade))
    assert grades != [plain, grade]  # as a tuple: not equal to a list
    assert pickle.loads(pickle.dumps(grades)) == (plain, grade)
    assert type(pickle.loads(pickle.dumps(grades))) is tuple


def test_a_packed_submission_copies_and_pickles_as_a_plain_one():
    grade = _grade()
    sub = _packed(grade).submission
    for other in (pickle.loads(pickle.dumps(sub)), copy.copy(sub)):
        assert type(other) is Submission and other == grade.submission
