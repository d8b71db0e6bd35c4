"""Rosters in plain, Canvas and Moodle form, in the encodings they arrive in."""

from __future__ import annotations

from pathlib import Path

import pytest

from gradekit.errors import ErrorList, GradekitError
from gradekit.roster import Student, read_roster

DATA = Path(__file__).parent / "data" / "grading"


def test_plain_roster_with_header_in_any_case(tmp_path: Path) -> None:
    path = tmp_path / "roster.csv"
    path.write_text(
        " Student ID , Name ,Email,Section\n123,Selam Haile,selam@uni.edu,A\n\n124,Abebe Kebede,,B\n"
    )
    assert read_roster(path) == [
        Student("123", "Selam Haile", "selam@uni.edu", "A"),
        Student("124", "Abebe Kebede", "", "B"),
    ]


def test_plain_roster_without_header(tmp_path: Path) -> None:
    path = tmp_path / "roster.csv"
    path.write_text("123,Selam Haile\n124,Abebe Kebede,ab@uni.edu\n")
    assert read_roster(path) == [Student("123", "Selam Haile"), Student("124", "Abebe Kebede", "ab@uni.edu")]


def test_canvas_export_skips_points_possible_and_reorders_names() -> None:
    students = read_roster(DATA / "canvas_roster.csv")
    assert students == [
        Student("S1001", "Selam Haile", section="MEG373-01", sis_login="shaile", lms_id="12345"),
        Student("S1002", "José Núñez", section="MEG373-01", sis_login="jnunez", lms_id="12346"),
        Student("12347", "Test Student", section="MEG373-01", lms_id="12347"),
    ]


def test_moodle_export() -> None:
    students = read_roster(DATA / "moodle_roster.csv")
    assert students == [
        Student("2001", "Selam Haile", email="selam@uni.edu", section="Lab 1"),
        Student("2002", "Chloé Dubois", email="chloe@uni.edu", section="Lab 2"),
    ]


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "cp1252", "latin-1"])
def test_encodings(tmp_path: Path, encoding: str) -> None:
    path = tmp_path / "roster.csv"
    path.write_bytes("student_id;name\n7;Zoë Müller\n".encode(encoding))
    assert read_roster(path) == [Student("7", "Zoë Müller")]


def test_every_bad_row_is_reported_once(tmp_path: Path) -> None:
    path = tmp_path / "roster.csv"
    path.write_text("student_id,name\n123,A\n124,B\n,C\n125,D,d@x,S1,extra\n126,E\n123,F\n")
    with pytest.raises(ErrorList) as info:
        read_roster(path)
    assert str(info.value.format_message()).splitlines() == [
        f"{path}:4: student_id: expected an id, got '' (for 'C')",
        f"{path}:5: row: expected at most 2 cells, got 5 ('d@x', 'S1', 'extra' extra)",
        f"{path}:7: student_id: expected a unique id, got '123' (also on row 2)",
    ]


def test_example_message_form(tmp_path: Path) -> None:
    path = tmp_path / "roster.csv"
    path.write_text("student_id,name\na,1\nb,2\n123,x\nc,3\nd,4\ne,5\n123,y\n")
    with pytest.raises(
        ErrorList, match=r"roster.csv:8: student_id: expected a unique id, got '123' \(also on row 4\)"
    ):
        read_roster(path)


def test_empty_and_binary_rosters(tmp_path: Path) -> None:
    empty = tmp_path / "empty.csv"
    empty.write_text("\n\n")
    with pytest.raises(GradekitError, match="got an empty file"):
        read_roster(empty)
    binary = tmp_path / "bin.csv"
    binary.write_bytes(b"\x00\x01\x02" * 50)
    with pytest.raises(GradekitError, match="got binary data"):
        read_roster(binary)
    with pytest.raises(GradekitError, match="expected a readable roster file"):
        read_roster(tmp_path / "missing.csv")


def test_moodle_export_of_a_site_without_id_numbers_keys_students_by_email(tmp_path: Path) -> None:
    path = tmp_path / "moodle.csv"
    path.write_text(
        "First name,Last name,ID number,Institution,Department,Email address,Assignment: HW 5 (Real),"
        "Last downloaded from this course\n"
        "Lars,de Vries,,Uni,,lars@uni.edu,-,1764000000\nSelam,Haile,2001,Uni,,selam@uni.edu,7.5,1764000000\n",
        encoding="utf-8",
    )
    assert read_roster(path) == [
        Student("lars@uni.edu", "Lars de Vries", email="lars@uni.edu"),
        Student("2001", "Selam Haile", email="selam@uni.edu"),
    ]


def test_moodle_grading_worksheet_keeps_the_participant_id(tmp_path: Path) -> None:
    """The participant id is the number Moodle's downloads and feedback zips put in folder names."""
    path = tmp_path / "Grades-HW5.csv"
    path.write_text(
        "Identifier,Full name,ID number,Email address,Status,Grade,Maximum Grade,Grade can be changed,"
        "Last modified (submission),Last modified (grade),Feedback comments\n"
        "Participant 4242,Lars de Vries,,lars@uni.edu,Submitted for grading,,60.00,Yes,,-,\n"
        "Participant 4243,Selam Haile,2001,selam@uni.edu,No submission,,60.00,Yes,-,-,\n",
        encoding="utf-8",
    )
    assert read_roster(path) == [
        Student("lars@uni.edu", "Lars de Vries", email="lars@uni.edu", lms_id="4242"),
        Student("2001", "Selam Haile", email="selam@uni.edu", lms_id="4243"),
    ]


def test_canvas_assignment_id_from_the_gradebook_export_header(tmp_path: Path) -> None:
    from gradekit.roster import canvas_assignment_id

    assert canvas_assignment_id(DATA / "canvas_roster.csv", "HW 1") == "111"
    assert canvas_assignment_id(DATA / "canvas_roster.csv", "  hw   1 ") == "111"  # case and spacing
    assert canvas_assignment_id(DATA / "canvas_roster.csv", "HW 2") == ""
    assert canvas_assignment_id(DATA / "moodle_roster.csv", "HW 1") == ""
    assert canvas_assignment_id(tmp_path / "missing.csv", "HW 1") == ""
