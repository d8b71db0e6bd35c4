"""Formula-injection-safe cells, atomic CSV writes and forgiving decoding."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from gradekit.csvsafe import decode_bytes, safe_cell, sniff_delimiter, write_csv


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ('=HYPERLINK("http://evil.example","click")', '\'=HYPERLINK("http://evil.example","click")'),
        ("-2+3", "'-2+3"),
        ("+1", "+1"),  # a plain number runs nothing: kept, so ids such as +1001 round-trip
        ("@SUM(A1:A9)", "'@SUM(A1:A9)"),
        ("\t=1", "'\t=1"),
        ("\r=1", "'\r=1"),
        ("Selam Haile", "Selam Haile"),
        ("a=b", "a=b"),
        ("", ""),
        (None, ""),
    ],
)
def test_text_that_a_spreadsheet_would_run_is_quoted(value: object, expected: str) -> None:
    assert safe_cell(value) == expected


@pytest.mark.parametrize("value", [-2, -2.5, 0, 3.25, np.float64(-1.5), np.int64(-7)])
def test_numbers_stay_numbers(value: object) -> None:
    assert safe_cell(value) is value


def test_write_csv_neutralises_every_cell_and_keeps_numbers(tmp_path: Path) -> None:
    path = tmp_path / "grades.csv"
    write_csv(path, ["student_id", "name", "total"], [["=1+1", '=HYPERLINK("x")', -2.5], ["@me", "-2+3", 4]])
    assert path.read_bytes().decode("utf-8") == (
        'student_id,name,total\r\n\'=1+1,"\'=HYPERLINK(""x"")",-2.5\r\n\'@me,\'-2+3,4\r\n'
    )
    with path.open(newline="") as handle:
        assert list(csv.reader(handle))[2] == ["'@me", "'-2+3", "4"]
    assert [p.name for p in tmp_path.iterdir()] == ["grades.csv"]  # no temp file left


def test_write_csv_replaces_atomically_and_keeps_old_file_on_error(tmp_path: Path) -> None:
    path = tmp_path / "grades.csv"
    write_csv(path, ["a"], [[1]])

    def rows():
        yield [2]
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError):
        write_csv(path, ["a"], rows())
    assert path.read_bytes() == b"a\r\n1\r\n"
    assert [p.name for p in tmp_path.iterdir()] == ["grades.csv"]


@pytest.mark.parametrize(
    ("data", "text", "encoding"),
    [
        ("ä;1".encode("utf-8-sig"), "ä;1", "utf-8"),
        ("ä;1".encode("utf-16"), "ä;1", "utf-16-le"),
        ("ä;1".encode("utf-16-le"), "ä;1", "utf-16-le"),
        ("ä;1".encode("cp1252"), "ä;1", "cp1252"),
        (b"\x81\xff", "\x81ÿ", "latin-1"),
        (b"plain", "plain", "utf-8"),
    ],
)
def test_decode_bytes(data: bytes, text: str, encoding: str) -> None:
    assert decode_bytes(data) == (text, encoding)


@pytest.mark.parametrize(
    ("text", "delimiter"),
    [("a,b,c\n1,2,3", ","), ("a;b;c\n1,2;3", ";"), ("a\tb\n1,5\t2", "\t"), ("\n\nonly", ","), ("", ",")],
)
def test_sniff_delimiter(text: str, delimiter: str) -> None:
    assert sniff_delimiter(text) == delimiter
