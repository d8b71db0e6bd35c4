"""Grading: read submissions, compare with the keys, flag copies, write grades and feedback."""

from gradekit.grading.batch import BatchResult, FileRecord, grade_batch, grade_students, read_submissions
from gradekit.grading.compare import (
    AnswerResult,
    StudentGrade,
    compare,
    diagnose,
    generic_mistakes,
    grade_class,
    grade_student,
)
from gradekit.grading.integrity import IntegrityFlag, find_copies
from gradekit.grading.reader import Answer, Issue, Submission, parse_value

__all__ = [
    "Answer",
    "AnswerResult",
    "BatchResult",
    "FileRecord",
    "IntegrityFlag",
    "Issue",
    "StudentGrade",
    "Submission",
    "compare",
    "diagnose",
    "find_copies",
    "generic_mistakes",
    "grade_batch",
    "grade_class",
    "grade_student",
    "grade_students",
    "parse_value",
    "read_submissions",
]
