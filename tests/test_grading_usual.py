"""The reader's path for the usual file (`reader._usual`) gives exactly what the full reader gives, and
leaves every other file to it: the same answers, the same messages."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gradekit.grading import reader
from gradekit.grading.reader import Answer, IdIndex, Issue, KeyIndex, Submission, read_file
from gradekit.roster import Student

STUDENTS = [Student("123", "Selam Haile", lms_id="98765"), Student("0456", "Abebe Kebede")]
KEYS = ("p1.T", "p1.F", "p1.theta")
HEAD = "student_id,key,value,unit\n"
NAME = "123_answers.csv"


def _both(tmp_path: Path, data: bytes, name: str = NAME):
    """(what read_file gives, what the full reader alone gives) for a file holding *data*."""
    path = tmp_path / name
    path.write_bytes(data)
    ids, keys = IdIndex(STUDENTS), KeyIndex(KEYS)
    fast = read_file(path, name, name, ids, keys)
    saved = reader._usual
    reader._usual = lambda *args: None
    try:
        full = read_file(path, name, name, ids, keys)
    finally:
        reader._usual = saved
    return fast, full


def _taken(tmp_path: Path, data: bytes) -> bool:
    """Whether the usual file's path reads *data* (else the full reader does)."""
    return reader._usual(data, NAME, "123", IdIndex(STUDENTS), KeyIndex(KEYS), 0.0) is not None


def test_the_usual_file_is_read_on_its_path_as_the_full_reader_reads_it(tmp_path):
    data = (HEAD + "123,p1.T,1.12,N*m\n123,p1.F,-250,N\n\n123,p1.theta,0.5,rad\n").encode()
    assert _taken(tmp_path, data)
    fast, full = _both(tmp_path, data)
    assert fast == full
    mtime = (tmp_path / NAME).stat().st_mtime
    assert fast == [
        Submission(NAME, "123", (
            Answer("p1.T", "1.12", "N*m", 1.12, "N*m", 2, "unit"),
            Answer("p1.F", "-250", "N", -250.0, "N", 3, "unit"),
            Answer("p1.theta", "0.5", "rad", 0.5, "rad", 5, "unit"),  # line 4 is blank
        ), (), (), True, mtime, False, "123", ())
    ]


def test_cells_that_are_not_plain_numbers_read_as_the_full_reader_reads_them(tmp_path):
    data = (HEAD + "123,p1.T,1120N*mm,\n123,p1.F,,N\n123,p1.theta,abc,rad\n,,,\n").encode()
    assert _taken(tmp_path, data)
    fast, full = _both(tmp_path, data)
    assert fast == full
    (sub,) = fast
    assert sub.issues == ()
    assert sub.answers[0] == Answer("p1.T", "1120N*mm", "", 1120.0, "N*mm", 2, "value")
    assert sub.answers[1] == Answer("p1.F", "", "N", None, "", 3, "value", "expected a number, got a blank cell")
    assert sub.answers[2] == Answer("p1.theta", "abc", "rad", None, "", 4, "value", "expected a number, got 'abc'")


@pytest.mark.parametrize(
    ("label", "data"),
    [
        ("BOM", b"\xef\xbb\xbf" + (HEAD + "123,p1.T,1.12,N*m\n").encode()),
        ("quoted", (HEAD + '123,p1.T,"1.12",N*m\n').encode()),
        ("quoted comma", (HEAD + '123,p1.T,"1,12",N*m\n').encode()),
        ("extra column", (HEAD + "123,p1.T,1.12,N*m,oops\n").encode()),
        ("empty extra column", (HEAD + "123,p1.T,1.12,N*m,\n").encode()),
        ("short row", (HEAD + "123,p1.T,1.12\n").encode()),
        ("CRLF", (HEAD + "123,p1.T,1.12,N*m\n").replace("\n", "\r\n").encode()),
        ("CR", (HEAD + "123,p1.T,1.12,N*m\n").replace("\n", "\r").encode()),
        ("bad UTF-8", (HEAD + "123,p1.T,1.12,N\xb7m\n").encode("latin-1")),
        ("UTF-8 unit", (HEAD + "123,p1.T,1.12,N·m\n").encode()),
        ("duplicate key", (HEAD + "123,p1.T,1.12,N*m\n123,p1.T,1.13,N*m\n").encode()),
        ("spaces", (HEAD + "123, p1.T ,1.12 ,N*m\n").encode()),
        ("tab", (HEAD + "123\tp1.T\t1.12\tN*m\n").encode()),
        ("other student's id", (HEAD + "0456,p1.T,1.12,N*m\n").encode()),
        ("blank id", (HEAD + ",p1.T,1.12,N*m\n").encode()),
        ("LMS id", (HEAD + "98765,p1.T,1.12,N*m\n").encode()),
        ("unknown key", (HEAD + "123,p9.X,1.12,N*m\n").encode()),
        ("key in other case", (HEAD + "123,P1.t,1.12,N*m\n").encode()),
        ("header only", HEAD.encode()),
        ("other header", (b"Student_ID,Key,Value,Unit\n123,p1.T,1.12,N*m\n")),
        ("no final newline", (HEAD + "123,p1.T,1.12,N*m").encode()),
        ("control character", (HEAD + "123,p1.T,1.12,N*m\x01\n").encode()),
        ("NUL", (HEAD + "123,p1.T,1.12,N*m\x00\n").encode()),
        ("semicolons", (b"student_id;key;value;unit\n123;p1.T;1,12;N*m\n")),
    ],
)
def test_every_other_file_is_left_to_the_full_reader(tmp_path, label, data):
    fast, full = _both(tmp_path, data)
    assert fast == full, label
    assert _taken(tmp_path, data) == (label == "no final newline"), label  # (a last line without LF is usual)


def test_what_the_full_reader_says_of_unusual_files_stays(tmp_path):
    """The messages themselves, written out (not taken from either reader)."""
    cases = {
        (HEAD + "123,p1.T,1.12,N*m\n123,p1.T,1.13,N*m\n").encode(): Issue(
            NAME, 3, "key", "expected each key once, got 'p1.T' again (first on line 2; this row is ignored)"),
        (HEAD + "123,p1.T,1.12,N*m,oops\n").encode(): Issue(NAME, 2, "row", "expected 4 cells, got 5 (a decimal "
                                                             "comma? write 1.12, or use ';' between columns)"),
        (HEAD + "0456,p1.T,1.12,N*m\n").encode(): Issue(
            NAME, None, "student_id",
            "expected '123' (the file name's student), got rows for '0456'; graded as '123' only, and never as '0456'"),
        (HEAD + "123,p9.X,1.12,N*m\n").encode(): Issue(
            NAME, 2, "key", "expected a key such as p1.F, p1.T, p1.theta, got 'p9.X'"),
    }
    for data, issue in cases.items():
        fast, full = _both(tmp_path, data)
        assert fast == full
        assert fast[0].issues == (issue,)
    fast, full = _both(tmp_path, (HEAD + '123,p1.T,"1,120",N*m\n').encode())
    assert fast == full
    assert fast[0].answers[0].issue == "expected a number with a decimal point, got '1,120'"
    fast, full = _both(tmp_path, (HEAD + "123,p1.T,1.12,N·m\n").encode("latin-1", "replace").replace(b"?", b"\xb7"))
    assert fast == full and fast[0].answers[0].raw_unit == "N·m"  # cp1252 read when not UTF-8
    fast, full = _both(tmp_path, b"\xef\xbb\xbf" + (HEAD + "123,p1.T,1.12,N*m\r\n").encode())
    assert fast == full and fast[0].answers == (Answer("p1.T", "1.12", "N*m", 1.12, "N*m", 2, "unit"),)


_CELLS = st.sampled_from
_ROW = st.tuples(
    _CELLS(["123", "123", "123", "0456", "", "98765", " 123"]),
    _CELLS([*KEYS, *KEYS, "p9.X", "", "P1.T"]),
    _CELLS(["1.12", "-250", "0.5", "1e3", "", "abc", "1e999", "nan", "1,120", "1120N*mm", "+.5", "1" * 90]),
    _CELLS(["N*m", "N", "rad", "", "deg", "x" * 70, "N m"]),
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(st.one_of(_ROW, st.just(None)), max_size=8), ending=st.sampled_from(["\n", ""]))
def test_files_near_the_usual_one_read_alike(tmp_path, rows, ending):
    """Rows drawn from usual and unusual cells (ids, keys, values, units), blank lines among them."""
    lines = ["" if r is None else ",".join(r) for r in rows]
    data = (HEAD + "\n".join(lines) + ending).encode()
    fast, full = _both(tmp_path, data)
    assert fast == full
