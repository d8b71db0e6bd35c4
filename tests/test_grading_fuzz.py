"""No byte content makes the reader or the comparison raise: thousands of malformed CSVs."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gradekit import units
from gradekit.errors import GradekitError
from gradekit.grading.compare import grade_student
from gradekit.grading.reader import IdIndex, KeyIndex, Submission, read_file
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Tolerance

STUDENTS = [Student("123", "A"), Student("456", "B", lms_id="789")]
KEYS = [
    KeyEntry(s.student_id, "p1", k, v, u, Tolerance("sigfigs", sigfigs=3))
    for s in STUDENTS
    for k, v, u in (("p1.T", 1.12, "N*m"), ("p1.F", 0.0, "N"), ("p2.w", -3.3, "rad/s"))
]
IDS = IdIndex(STUDENTS)
KEYIDX = KeyIndex(e.key for e in KEYS)

CELLS = st.one_of(
    st.sampled_from(
        [
            "student_id",
            "key",
            "value",
            "unit",
            "123",
            "456",
            "789",
            "p1.T",
            "P1.t",
            "p1.F",
            "p2.w",
            "1,12",
            "1.12",
            "-1e3",
            "nan",
            "inf",
            "1120 N*mm",
            "kN",
            "lb*in",
            "m**99999",
            "deg",
            "°",
            "",
            " ",
            '"',
            "'",
            "=1+1",
            "\ufeff",
            "\x00",
            "1.12x10^999",
            "1,120",
            "1.2.3",
            "rad/s^2",
            "((",
            "N*m)",
            "1e-400",
        ]
    ),
    st.text(max_size=12),
    st.integers(min_value=0, max_value=300_000).map(lambda n: "x" * n),
)
ROWS = st.lists(st.lists(CELLS, max_size=7), max_size=8)
SEPARATORS = st.sampled_from([",", ";", "\t", "|", ""])
ENCODINGS = st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "cp1252", "latin-1"])
NEWLINES = st.sampled_from(["\n", "\r\n", "\r"])


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


def check(folder: Path, data: bytes, name: str = "x.csv") -> None:
    path = folder / "sub.csv"
    path.write_bytes(data)
    subs = read_file(path, name, name, IDS, KEYIDX)
    assert subs and all(isinstance(s, Submission) for s in subs)
    for sub in subs:
        assert all(str(i).startswith(name) for i in sub.issues)
        student = STUDENTS[0] if sub.student_id != "456" else STUDENTS[1]
        entries = [e for e in KEYS if e.student_id == student.student_id]
        grade = grade_student(student, entries, sub)
        assert 0 <= grade.total <= grade.max_points == 3


FAST = settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FAST
@given(st.binary(max_size=3000))
def test_random_bytes(folder: Path, data: bytes) -> None:
    check(folder, data)


@FAST
@given(ROWS, SEPARATORS, ENCODINGS, NEWLINES, st.booleans())
def test_random_tables(folder: Path, rows: list[list[str]], sep: str, encoding: str, newline: str, quote: bool) -> None:
    cells = [[f'"{c}"' if quote and i % 2 else c for i, c in enumerate(row)] for row in rows]
    text = newline.join(sep.join(row) for row in cells)
    check(folder, text.encode(encoding, errors="replace"), name="hailesel_789_1_answers.csv")


@FAST
@given(st.text(alphabet=st.sampled_from(list(",;\t\"'\n\r\ufeff\x00 0123456789.eE-+NaNk*mp1T_")), max_size=400))
def test_random_text_of_csv_characters(folder: Path, text: str) -> None:
    check(folder, text.encode("utf-8", errors="surrogatepass"))


NAME_PARTS = st.sampled_from(
    ["123", "456", "789", "0456", "hailesel", "A", "B", "late", "LATE", "1", "_", "-", " ", ".", "/",
     "assignsubmission_file_", "answers", ".csv", "é", "\udcff", "..", "=", "'"]
)


@FAST
@given(st.lists(NAME_PARTS, max_size=10).map("".join))
def test_random_file_names(folder: Path, name: str) -> None:
    found = IDS.from_path(name)
    assert found <= {"123", "456"}
    check(folder, b"key,value,unit\np1.T,1.12,N*m\n", name=name or "x")


UNIT_TEXT = st.text(alphabet=st.sampled_from(list("NmkKlbfinftsMrad°/*^·.-_ 0123456789()²e")), max_size=60)


@FAST
@given(UNIT_TEXT)
def test_random_units_never_raise_anything_but_a_data_error(unit: str) -> None:
    try:
        factor = units.factor(unit, "N*m")
    except GradekitError as exc:
        assert exc.detail.startswith("expected a unit")
    else:
        assert factor == factor  # a number, not NaN


@FAST
@given(ROWS, st.sampled_from(["utf-16-le", "utf-16-be"]), st.sampled_from([",", ";", "\t"]))
def test_bomless_utf16_tables(folder: Path, rows: list[list[str]], encoding: str, sep: str) -> None:
    text = "\r\n".join(sep.join(row) for row in [["student_id", "key", "value", "unit"], *rows])
    check(folder, text.encode(encoding, errors="replace"))


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX special files")
def test_special_files_are_refused_without_being_opened(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "fifo.csv")
    os.symlink("/dev/zero", tmp_path / "zero.csv")
    os.symlink("/etc/passwd", tmp_path / "passwd.csv")
    (tmp_path / "dir.csv").mkdir()
    kinds = {
        "fifo.csv": "a FIFO (named pipe)",
        "zero.csv": "a symbolic link",
        "passwd.csv": "a symbolic link",
        "dir.csv": "a folder",
    }
    for name, kind in kinds.items():
        [sub] = read_file(tmp_path / name, name, name, IDS, KEYIDX)
        assert not sub.readable
        assert [str(i) for i in sub.issues] == [f"{name}: file: expected a regular file, got {kind}"]
