"""The LMS round trip: canvas.csv as Canvas imports it, and feedback zips in the layouts Moodle's and
Canvas's bulk uploads read, checked against the LMSs' own rules for those names."""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path

import pytest

from gradekit.errors import GradekitError
from gradekit.grading import grade_batch
from gradekit.grading.exports import EXPORTS, GradedClass, choose_exports, write_exports
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Tolerance

STUDENTS = [
    Student("1001", "Selam Haile", "selam@uni.edu", "A"),
    Student("1002", "Lars de Vries", "lars@uni.edu", "A"),
    Student("1003", "Zoë Núñez", "zoe@uni.edu", "B"),
    Student("1004", "Ada Lee", "ada@uni.edu", "B", lms_id="5150"),  # from a Canvas roster: its user id
]
VALUES = {"1001": 1.5, "1002": 2.5, "1003": 3.5, "1004": 4.5}

# the names the LMS downloads give the files: Canvas lastfirst_userid_attachmentid_name (late), Moodle's
# participant folder (Moodle before 4.1 ends it with "_"), and a plain file
FILES = {
    "1001": "haileselam_4242_9001_answers.csv",
    "1002": "Lars de Vries_777_assignsubmission_file_/answers.csv",
    "1003": "1003.csv",
    "1004": "leeada_late_5150_9002_answers-1.csv",
}


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    root = tmp_path_factory.mktemp("lms")
    keys = [KeyEntry(sid, "p1", "p1.T", v, "N*m", Tolerance(rel=0.01), 2.0) for sid, v in VALUES.items()]
    sub = root / "submissions"
    for sid, name in FILES.items():
        path = sub / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"student_id,key,value,unit\n{sid},p1.T,{VALUES[sid]},N*m\n", encoding="utf-8")
    result = grade_batch(keys, STUDENTS, sub, root / "out", assignment_title="HW 5")
    out = root / "exports"
    out.mkdir()
    graded = GradedClass(result.grades, ["p1"], {}, "HW 5", canvas_assignment_id="123456")
    written = write_exports(out, graded, list(EXPORTS))
    return root, out, written


def test_canvas_csv_is_canvas_gradebook_import(graded) -> None:
    _, out, _ = graded
    rows = list(csv.reader(io.StringIO((out / "canvas.csv").read_text(encoding="utf-8"))))
    assert rows[0] == ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", "HW 5 (123456)"]
    by_sis = {r[2]: r for r in rows[1:]}
    assert by_sis["1001"][:2] == ["Selam Haile", "4242"]  # the Canvas user id from the Canvas file name
    assert by_sis["1002"][:2] == ["Lars de Vries", ""]  # never "Vries, Lars de"; Moodle's id is no Canvas id
    assert by_sis["1003"][:2] == ["Zoë Núñez", ""]
    assert by_sis["1004"][:2] == ["Ada Lee", "5150"]  # the roster's
    assert [r[-1] for r in rows[1:]] == ["2", "2", "2", "2"]


def moodle_import_rule(member: str) -> tuple[str, str, str] | None:
    """What Moodle's feedback zip import reads from a path (assignfeedback_file_zip_importer::
    is_valid_filename_for_import): the first path part that splits at "_" (at most 5 pieces) into at
    least 4, the second numeric: (participant id, plugin type, plugin name)."""
    for part in member.split("/"):
        info = part.split("_", 4)
        if len(info) >= 4 and info[1].isdigit():
            return info[1], info[2], info[3]
    return None


def test_moodle_feedback_zip_has_a_folder_per_participant_as_moodle_names_it(graded) -> None:
    root, out, _ = graded
    with zipfile.ZipFile(out / "moodle-feedback.zip") as z:
        assert z.namelist() == ["Lars de Vries_777_assignsubmission_file_/feedback.html"]
        assert moodle_import_rule(z.namelist()[0]) == ("777", "assignsubmission", "file")
        page = z.read(z.namelist()[0])
    assert page == (out / "feedback" / "1002.html").read_bytes()
    assert str(root).encode() not in page and b"Graded file: <code>answers.csv</code>" in page


def canvas_reupload_rule(name: str) -> tuple[str, str] | None:
    """What Canvas's "Re-upload submissions" reads from a file name
    (Assignment#infer_comment_context_from_filename): the first two all-digit "_" parts."""
    digits = [p for p in name.split("/")[-1].split("_") if p.isdigit()][:2]
    return (digits[0], digits[1]) if len(digits) == 2 else None


def test_canvas_feedback_zip_names_each_file_for_the_submission_it_comments(graded) -> None:
    _, out, _ = graded
    with zipfile.ZipFile(out / "canvas-feedback.zip") as z:
        names = z.namelist()
        assert names == ["haileselam_4242_9001_feedback.html", "leeada_late_5150_9002_feedback.html"]
        assert [canvas_reupload_rule(n) for n in names] == [("4242", "9001"), ("5150", "9002")]
        assert z.read(names[1]) == (out / "feedback" / "1004.html").read_bytes()


def test_feedback_never_shows_the_instructors_disk(graded) -> None:
    root, out, _ = graded
    pages = list((out / "feedback").iterdir())
    assert len(pages) == 8
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert str(root) not in text and "submissions" not in text
    assert "Graded file: answers-1.csv" in (out / "feedback" / "1004.md").read_text(encoding="utf-8")


def test_exports_are_chosen_by_name(graded, tmp_path: Path) -> None:
    _, out, written = graded
    assert {p.name for p in written} >= {"grades.csv", "canvas.csv", "moodle.csv", "report.md", "histogram.svg",
                                        "moodle-feedback.zip", "canvas-feedback.zip"}
    assert choose_exports(None) == ("grades", "canvas", "moodle", "feedback", "report", "hand", "histogram")
    assert choose_exports(["report", "grades"]) == ("grades", "report")  # in the table's order
    only = tmp_path / "only"
    only.mkdir()
    grades = GradedClass(grade_batch([KeyEntry("1", "p1", "p1.T", 1.0, "N*m", Tolerance())], [Student("1", "A")],
                                     _one_file(tmp_path), tmp_path / "o").grades, ["p1"], {}, "HW")
    write_exports(only, grades, ["grades", "report"])
    assert sorted(p.name for p in only.iterdir()) == ["grades.csv", "report.md"]
    assert "histogram" not in (only / "report.md").read_text(encoding="utf-8")  # no image it does not have
    with pytest.raises(GradekitError, match=r"hw5\.yaml: exports: expected exports among grades, canvas, .*; "
                                            r"got 'moodle-zip' \(did you mean 'moodle'\?\)"):
        choose_exports(["grades", "moodle-zip"], "hw5.yaml")


def _one_file(tmp_path: Path) -> Path:
    sub = tmp_path / "s"
    sub.mkdir()
    (sub / "1.csv").write_text("student_id,key,value,unit\n1,p1.T,1,N*m\n", encoding="utf-8")
    return sub


def test_an_assignment_chooses_its_exports(tmp_path: Path) -> None:
    from gradekit.assignment import load_assignment

    head = "title: HW\ncourse: MEG373\nsalt: s\nproblems:\n  - {id: ch5-ex5-1, points: 10}\n"
    good = tmp_path / "good.yaml"
    good.write_text(head + "exports: [report, moodle-feedback-zip, grades]\n", encoding="utf-8")
    assert load_assignment(good).exports == ("grades", "report", "moodle-feedback-zip")
    plain = tmp_path / "plain.yaml"
    plain.write_text(head, encoding="utf-8")
    assert load_assignment(plain).exports is None  # the default set
    bad = tmp_path / "bad.yaml"
    bad.write_text(head + "exports: [grades, canvass]\n", encoding="utf-8")
    with pytest.raises(GradekitError) as info:
        load_assignment(bad)
    assert info.value.format_message() == (
        f"{bad}:6: exports: expected exports among {', '.join(EXPORTS)}; got 'canvass' (did you mean 'canvas'?)")
