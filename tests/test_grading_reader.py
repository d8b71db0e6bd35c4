"""The submission reader on the messy files students and LMSs really produce."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from gradekit.grading.batch import read_submissions
from gradekit.grading.compare import grade_student
from gradekit.grading.reader import IdIndex, KeyIndex, parse_value, read_file
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Tolerance

STUDENTS = [Student("123", "Selam Haile", lms_id="98765"), Student("0456", "Abebe Kebede")]
KEYS = [
    KeyEntry(sid, "p1", key, value, unit, Tolerance("relative", rel=0.01), points=1.0)
    for sid in ("123", "0456")
    for key, value, unit in (("p1.T", 1.12, "N*m"), ("p1.F", -250.0, "N"), ("p1.theta", 0.5, "rad"))
]
MINE = [e for e in KEYS if e.student_id == "123"]


def read(tmp_path: Path, name: str, data: bytes):
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return read_file(path, name, name, IdIndex(STUDENTS), KeyIndex(e.key for e in KEYS))


@pytest.mark.parametrize(
    ("text", "comma", "expected"),
    [
        ("1.12", False, (1.12, "")),
        (" 1,12 ", True, (1.12, "")),
        ("1,12", False, (1.12, "")),
        ("-1.2e3", False, (-1200.0, "")),
        ("1.12E-03", False, (0.00112, "")),
        ("1.12x10^3", False, (1120.0, "")),
        ("1120 N*mm", False, (1120.0, "N*mm")),
        ("1120N·mm", False, (1120.0, "N·mm")),
        ("\u22125.5 kN", False, (-5.5, "kN")),
        ("+.5 [rad]", False, (0.5, "rad")),
        ("238,542.2", False, (238542.2, "")),  # thousands and a decimal mark: unambiguous (issue 29)
        ("213.830,3", True, (213830.3, "")),
        ("213.830,3 N", False, (213830.3, "N")),
        ("1,234,567", False, (1234567.0, "")),
        ("1.234.567 N", True, (1234567.0, "N")),
        ("1,120", True, (1.12, "")),  # a decimal comma where the delimiter is not the comma
        ("1.120", False, (1.12, "")),
    ],
)
def test_parse_value(text: str, comma: bool, expected: tuple[float, str]) -> None:
    value, unit = parse_value(text, decimal_comma=comma)
    assert (pytest.approx(value), unit) == expected


@pytest.mark.parametrize(
    ("text", "comma", "message"),
    [
        ("", False, "expected a number, got a blank cell"),
        ("abc", False, "expected a number, got 'abc'"),
        ("NaN", False, "expected a finite number, got 'NaN'"),
        ("-inf", False, "expected a finite number, got '-inf'"),
        ("1e999", False, "expected a finite number, got '1e999'"),
        ("1.12x10^999", False, "expected a finite number, got '1.12x10^999'"),
        ("1,120", False, "expected a number whose comma is unambiguous (write 1.12 for a decimal, 1120 for "
                         "thousands), got '1,120'"),
        ("1,12,5", False, "expected one number, with one decimal mark and any thousands in groups of three, got "
                          "'1,12,5'"),
        ("1.120.5", False, "expected one number, with one decimal mark and any thousands in groups of three, got "
                           "'1.120.5'"),
        ("12,34.5", False, "expected one number, with one decimal mark and any thousands in groups of three, got "
                           "'12,34.5'"),
        ("1 120", True, "expected one number, with one decimal mark and any thousands in groups of three, got "
                        "'1 120'"),
    ],
)
def test_parse_value_refuses(text: str, comma: bool, message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        parse_value(text, decimal_comma=comma)


def test_utf16_tab_decimal_comma_odd_header(tmp_path: Path) -> None:
    text = (
        " Student ID \t KEY\tValue \tUNIT\r\n\r\n"
        "123\tp1.T\t1,12\tN·m\r\n123\tP1.F\t-0,25\tkN\r\n123\tp1.theta\t28,65\tdeg\r\n"
    )
    [sub] = read(tmp_path, "a.csv", text.encode("utf-16"))
    assert sub.student_id == "123" and sub.issues == ()
    grade = grade_student(STUDENTS[0], MINE, sub)
    assert [r.correct for r in grade.results] == [True, True, True]
    assert [r.value for r in grade.results] == pytest.approx([1.12, -250.0, 0.500037])
    assert [a.line for a in sub.answers] == [3, 4, 5]


def test_every_problem_is_named_with_file_row_and_column(tmp_path: Path) -> None:
    text = (
        "student_id,key,value,unit\n"
        "123,p1.T,abc,N*m\n"
        "123,p1.X,1,N\n"
        "123,p1.T,1.12,N*m\n"
        ",,,\n"
        "123,p1.F,1,2,N\n"
        "123,p1.theta,3,kg\n"
    )
    [sub] = read(tmp_path, "sub/x.csv", text.encode())
    grade = grade_student(STUDENTS[0], MINE, sub)
    assert [str(i) for i in grade.issues] == [
        "sub/x.csv:3: key: expected a key such as p1.F, p1.T, p1.theta, got 'p1.X'",
        "sub/x.csv:4: key: expected each key once, got 'p1.T' again (first on line 2; this row is ignored)",
        "sub/x.csv:6: row: expected 4 cells, got 5 (a decimal comma? write 1.12, or use ';' between columns)",
        "sub/x.csv:2: value: expected a number, got 'abc'",
        "sub/x.csv:7: unit: expected a unit of the same kind as 'rad', got 'kg'",
        "sub/x.csv: key: expected an answer for 'p1.F', got none",
    ]
    assert grade.total == 0


def test_lms_renamed_file_without_id_column(tmp_path: Path) -> None:
    [sub] = read(tmp_path, "hailesel_LATE_98765_67890_answers.csv", b"key,value\np1.T,1120 N*mm\n")
    assert sub.student_id == "123"  # Canvas user id 98765 in the name


def test_excel_mangled_id_and_name_mismatch(tmp_path: Path) -> None:
    [sub] = read(tmp_path, "123_answers.csv", b"student_id,key,value,unit\n456,p1.T,1,N*m\n")
    assert sub.student_id == "123"  # the file name wins: the file is 123's, never 0456's
    assert sub.conflicts == ("0456",)  # lost leading zero still matches the roster
    assert [str(i) for i in sub.issues] == [
        "123_answers.csv: student_id: expected '123' (the file name's student), got rows for '0456'; "
        "graded as '123' only, and never as '0456'"
    ]
    [sub] = read(tmp_path, "answers.csv", b"student_id,key,value,unit\n456,p1.T,1,N*m\n")
    assert (sub.student_id, sub.conflicts, sub.issues) == ("0456", (), ())  # no name: the column decides


def test_headerless_rows_and_wide_class_file(tmp_path: Path) -> None:
    [sub] = read(tmp_path, "h.csv", b"123,p1.T,1.12,N*m\n123,p1.F,-250,N\n")
    assert (sub.student_id, [a.key for a in sub.answers]) == ("123", ["p1.T", "p1.F"])
    subs = read(
        tmp_path, "class.csv", b"student_id,p1.T,p1.F,p1.theta\n123,1.12,-250,0.5\n0456,1,2,3\n777,1,2,3\n"
    )
    assert [(s.student_id, len(s.answers), s.claimed) for s in subs] == [
        ("123", 3, ()),
        ("0456", 3, ()),
        (None, 0, ("777",)),
    ]
    assert grade_student(STUDENTS[0], MINE, subs[0]).total == 3


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"", "x.csv: file: expected a CSV with columns student_id,key,value,unit, got an empty file"),
        (b"\n \r\n", "x.csv: file: expected a CSV with columns student_id,key,value,unit, got an empty file"),
        (
            b"PK\x03\x04rest",
            "x.csv: file: expected a CSV text file, got a zip or Excel workbook (save it as CSV)",
        ),
        (b"%PDF-1.4", "x.csv: file: expected a CSV text file, got a PDF"),
        (b"\x00\x01\x02\x03" * 10, "x.csv: file: expected a CSV text file, got binary data"),
        (
            b"hello,world\n1,2\n",
            "x.csv:1: header: expected a header row student_id,key,value,unit, got 'hello,world'",
        ),
        (
            b'a,"' + b"x" * 200_000 + b'"\n',
            "x.csv: file: expected a CSV file, got unreadable CSV (field larger",
        ),
    ],
)
def test_unreadable_files_say_why(tmp_path: Path, data: bytes, message: str) -> None:
    [sub] = read(tmp_path, "x.csv", data)
    assert not sub.readable
    assert str(sub.issues[0]).startswith(message)


def test_several_files_for_one_student_latest_wins(tmp_path: Path) -> None:
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "123_v1.csv").write_text("student_id,key,value\n123,p1.T,9\n")
    (sub / "123_v2.csv").write_text("student_id,key,value\n123,p1.T,1.12\n")
    (sub / "broken_123.csv").write_bytes(b"\x00" * 10)
    (sub / ".DS_Store").write_bytes(b"\x00")
    os.utime(sub / "123_v1.csv", (1_000, 1_000))
    os.utime(sub / "123_v2.csv", (2_000, 2_000))
    intake = read_submissions(sub, STUDENTS, KEYS)
    assert intake.chosen["123"].path == str(sub / "123_v2.csv")
    assert [(Path(f.path).name, f.status, f.detail) for f in intake.files] == [
        ("123_v1.csv", "duplicate", f"123: graded {sub / '123_v2.csv'} instead"),
        ("123_v2.csv", "graded", "student 123"),
        (
            "broken_123.csv",
            "unreadable",
            f"123: graded {sub / '123_v2.csv'} instead; {sub / 'broken_123.csv'}: file: expected a CSV text "
            "file, got binary data",
        ),
        (".DS_Store", "ignored", "hidden or system file"),
    ]


def test_full_width_digits_read_as_a_number():
    """An East Asian keyboard's full-width input (issue 26 item 18): ４０．８５ is 40.85, not 'expected a unit'."""
    from gradekit.grading import parse_value

    assert parse_value("４０．８５", decimal_comma=False) == (40.85, "")
    assert parse_value("－１２．５ N", decimal_comma=False) == (-12.5, "N")


@pytest.mark.parametrize(("text", "expected"), [("-68,52300", -68.523), ("1,12000", 1.12), ("0,125", 0.125)])
def test_a_decimal_comma_with_more_digits_is_no_thousands_separator(text, expected):
    from gradekit.grading import parse_value

    assert parse_value(text, decimal_comma=True) == (pytest.approx(expected), "")
