"""Batch grading of a small messy class, as an instructor would expect it."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from gradekit.errors import GradekitError
from gradekit.grading import FileRecord, grade_batch
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Mistake, Tolerance

IDS = ["1001", "1002", "1003", "1004", "1005", "1006", "1007", "1008", "1009", "1010"]
NAMES = [
    "Ada Lee",
    "Ben Oku",
    "Cleo Park",
    "Dan Roy",
    "Eve Sato",
    "Fay Ulm",
    "Gus Vo",
    "Hal Wu",
    "Ivy Jones",
    "Jon Zee",
]


def key_values(i: int) -> dict[str, float]:
    """Student i's answers: p1.T in N*m, p1.F in N, p2.a in m/s**2."""
    scale = 1 + 0.1 * i
    return {"p1.T": 1.1234 * scale, "p1.F": -52.71 * scale, "p2.a": 9.4321 * scale}


def make_keys() -> list[KeyEntry]:
    tol = Tolerance("relative", rel=0.01)
    units = {"p1.T": "N*m", "p1.F": "N", "p2.a": "m/s**2"}
    keys = []
    for i, sid in enumerate(IDS):
        for key, value in key_values(i).items():
            mistakes = ()
            if key == "p2.a":
                mistakes = (Mistake("gravity left out", "weight not included", value - 9.81),)
            keys.append(
                KeyEntry(
                    student_id=sid,
                    problem=key.split(".")[0],
                    key=key,
                    value=value,
                    unit=units[key],
                    tolerance=tol,
                    points=2.0 if key == "p1.T" else 1.0,
                    sign_convention="counter-clockwise positive" if key == "p1.T" else "",
                    mistakes=mistakes,
                )
            )
    return keys


def long_csv(sid: str, values: dict[str, str], units: dict[str, str] | None = None, sep: str = ",") -> str:
    units = units or {"p1.T": "N*m", "p1.F": "N", "p2.a": "m/s**2"}
    lines = [sep.join(["student_id", "key", "value", "unit"])]
    lines += [sep.join([sid, k, v, units.get(k, "")]) for k, v in values.items()]
    return "\n".join(lines) + "\n"


def exact(i: int) -> dict[str, str]:
    return {k: repr(v) for k, v in key_values(i).items()}


@pytest.fixture
def batch(tmp_path: Path):
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "1001.csv").write_text(long_csv("1001", exact(0)))
    (sub / "1002.csv").write_text(long_csv("1002", {k: f"{v:.3g}" for k, v in key_values(1).items()}))
    cleo = key_values(2)
    (sub / "1003.csv").write_text(
        long_csv(
            "1003",
            {
                "p1.T": f"{cleo['p1.T'] * 1000:.6g} N*mm",
                "p1.F": repr(cleo["p1.F"] / 1000),
                "p2.a": repr(cleo["p2.a"]),
            },
            {"p1.T": "", "p1.F": "kN", "p2.a": "m/s^2"},
        )
    )
    dan = {k: f"{v:.5f}".replace(".", ",") for k, v in key_values(3).items()}
    (sub / "1004.csv").write_bytes(("\ufeff" + long_csv("1004", dan, sep=";")).encode("utf-8"))
    eve = exact(4)
    eve["p1.T"] = repr(-key_values(4)["p1.T"])
    (sub / "1005.csv").write_text(long_csv("1005", eve))
    fay = exact(5)
    fay["p1.F"] = ""
    (sub / "1006.csv").write_text(long_csv("1006", fay))
    (sub / "1007.csv").write_bytes(bytes(range(256)) * 4)
    (sub / "1008.csv").write_text(long_csv("1008", exact(0)))  # Ada's answers
    (sub / "ivy_jones_1009_67890_answers.csv").write_text(long_csv("", exact(8)))
    (sub / "9999.csv").write_text(long_csv("9999", exact(0)))
    students = [Student(sid, name, email=f"{sid}@uni.edu") for sid, name in zip(IDS, NAMES, strict=True)]
    out = tmp_path / "out"
    result = grade_batch(make_keys(), students, sub, out, assignment_title="HW 3", reveal=False)
    return result, out, sub


def rows(path: Path) -> list[list[str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.reader(handle))


def test_scores_are_what_an_instructor_expects(batch) -> None:
    result, out, _ = batch
    table = rows(out / "grades.csv")
    assert table[0] == ["student_id", "name", "p1", "p2", "total", "max", "percent"]
    scores = {r[0]: r[2:] for r in table[1:]}
    assert scores == {
        "1001": ["3", "1", "4", "4", "100.0"],
        "1002": ["3", "1", "4", "4", "100.0"],
        "1003": ["3", "1", "4", "4", "100.0"],
        "1004": ["3", "1", "4", "4", "100.0"],
        "1005": ["1", "1", "2", "4", "50.0"],
        "1006": ["2", "1", "3", "4", "75.0"],
        "1007": ["0", "0", "0", "4", "0.0"],
        "1008": ["0", "0", "0", "4", "0.0"],
        "1009": ["3", "1", "4", "4", "100.0"],
        "1010": ["0", "0", "0", "4", "0.0"],
    }
    assert result.graded == 9
    assert result.ok and not result.clean
    assert [s.student_id for s in result.missing] == ["1010"]


def test_sign_flip_is_diagnosed(batch) -> None:
    result, out, _ = batch
    eve = next(g for g in result.grades if g.student.student_id == "1005")
    torque = next(r for r in eve.results if r.entry.key == "p1.T")
    assert not torque.correct
    assert torque.diagnosis is not None and torque.diagnosis.name == "sign flipped"
    assert torque.rel_error == pytest.approx(2.0)
    text = (out / "feedback" / "1005.md").read_text()
    # without --reveal a sign flip is not named (the student would flip their answer to the key)
    assert "sign flipped" not in text and "check the sign convention, the units and the component asked" in text
    assert "| p1.T |" in text and "| wrong | too low, outside the tolerance |" in text and "200 %" not in text


def test_messages_name_file_row_and_column(batch) -> None:
    result, _, sub = batch
    fay = next(g for g in result.grades if g.student.student_id == "1006")
    assert [str(i) for i in fay.issues] == [f"{sub}/1006.csv:3: value: expected a number, got a blank cell"]
    files = {Path(f.path).name: f for f in result.files}
    assert files["1007.csv"].status == "unreadable"
    assert files["1007.csv"].detail.startswith(f"{sub}/1007.csv: file: expected a CSV text file, got binary data")
    assert files["9999.csv"].status == "unknown student"
    assert files["9999.csv"].detail == "unknown student '9999'"
    assert files["ivy_jones_1009_67890_answers.csv"].status == "graded"
    assert files["ivy_jones_1009_67890_answers.csv"].detail == "student 1009"
    assert {f.status for f in result.files} == {"graded", "unreadable", "unknown student"}


def test_unit_conversion_and_decimal_comma_are_read(batch) -> None:
    result, _, _ = batch
    cleo = next(g for g in result.grades if g.student.student_id == "1003")
    torque = next(r for r in cleo.results if r.entry.key == "p1.T")
    assert torque.answer is not None and torque.answer.unit == "N*mm"
    assert torque.value == pytest.approx(key_values(2)["p1.T"], rel=1e-6)
    dan = next(g for g in result.grades if g.student.student_id == "1004")
    force = next(r for r in dan.results if r.entry.key == "p1.F")
    assert force.answer is not None and force.answer.raw == "-68,52300"
    assert force.value == pytest.approx(-68.523)


def test_copy_is_flagged_with_evidence(batch) -> None:
    result, out, _ = batch
    assert [(f.student_id, f.other_id, f.own_matches, f.other_matches, f.keys) for f in result.flags] == [
        ("1008", "1001", 0, 3, ("p1.T", "p1.F", "p2.a"))
    ]
    report = (out / "report.md").read_text()
    assert "1008 matches 1001's key on 3 answers (p1.T, p1.F, p2.a) but their own on 0" in report


def test_outputs_are_written_and_lms_imports_have_standard_columns(batch) -> None:
    result, out, _ = batch
    canvas = rows(out / "canvas.csv")
    assert canvas[0] == ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", "HW 3"]
    assert canvas[1] == ["Ada Lee", "", "1001", "", "", "4"]  # the name as the roster gives it, never cut
    ivy = next(r for r in canvas if r[2] == "1009")
    assert ivy[1] == "1009"  # the Canvas user id in the name Canvas gave her file (ivy_jones_1009_67890_…)
    moodle = rows(out / "moodle.csv")
    assert moodle[0] == ["ID number", "Email address", "HW 3"]
    assert moodle[5] == ["1005", "1005@uni.edu", "2"]
    assert (out / "histogram.svg").read_text(encoding="utf-8").startswith("<svg ")
    assert len(list((out / "feedback").glob("*.html"))) == 10
    report = (out / "report.md").read_text()
    assert "| p1.T | 67 % (6/9) | 8 | sign flipped (1) |" in report
    for name in ("1001.csv", "1007.csv", "9999.csv", "ivy\\_jones\\_1009\\_67890\\_answers.csv"):
        assert name in report
    assert "- 1010 Jon Zee" in report


def test_correct_values_only_revealed_on_request(tmp_path: Path, batch) -> None:
    result, out, sub = batch
    assert "Correct answer" not in (out / "feedback" / "1001.md").read_text()
    students = [g.student for g in result.grades]
    grade_batch(make_keys(), students, sub, out, reveal=True)  # a rerun into its own output folder
    text = (out / "feedback" / "1005.md").read_text()
    assert "Correct answer" in text and "1.57276 N·m (±1 %)" in text


def test_submission_folder_is_only_read(batch) -> None:
    _, _, sub = batch
    assert sorted(p.name for p in sub.iterdir()) == sorted(
        [
            "1001.csv",
            "1002.csv",
            "1003.csv",
            "1004.csv",
            "1005.csv",
            "1006.csv",
            "1007.csv",
            "1008.csv",
            "ivy_jones_1009_67890_answers.csv",
            "9999.csv",
        ]
    )


def test_missing_folder_raises_and_foreign_output_folder_is_refused(tmp_path: Path) -> None:
    students = [Student("1001", "Ada Lee")]
    with pytest.raises(GradekitError, match="expected a folder of submission CSVs"):
        grade_batch(make_keys(), students, tmp_path / "nope", tmp_path / "out")
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "1001.csv").write_text(long_csv("1001", exact(0)))
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.docx").write_text("precious")
    with pytest.raises(GradekitError, match="expected an empty output folder or one gradekit wrote before"):
        grade_batch(make_keys(), students, sub, mine)
    assert (mine / "thesis.docx").read_text() == "precious"


def test_class_wide_file_moodle_folders_and_output_inside_submissions(tmp_path: Path) -> None:
    sub = tmp_path / "sub"
    (sub / "Ivy Jones_1009_assignsubmission_file_").mkdir(parents=True)
    (sub / "Ivy Jones_1009_assignsubmission_file_" / "answers.csv").write_text(
        "key;value;unit\n"
        + "".join(f"{k};{v:.4f};\n".replace(f"{v:.4f}", f"{v:.4f}".replace(".", ",")) for k, v in key_values(8).items())
    )
    wide = ["student_id,p1.T,p1.F,p2.a"]
    wide += [f"{IDS[i]}," + ",".join(f"{v:.4g}" for v in key_values(i).values()) for i in (0, 1)]
    wide.append("4242,1,2,3")
    (sub / "class.csv").write_text("\n".join(wide) + "\n")
    students = [Student(sid, name) for sid, name in zip(IDS, NAMES, strict=True)]
    out = sub / "graded"
    result = grade_batch(make_keys(), students, sub, out, histogram=False)
    assert [(g.student.student_id, g.total) for g in result.grades if g.submission] == [
        ("1001", 4.0),
        ("1002", 4.0),
        ("1009", 4.0),
    ]
    assert [(Path(f.path).name, f.status, f.detail) for f in result.files] == [
        ("class.csv", "graded", "class-wide: 2 students graded; unknown student '4242'"),
        ("answers.csv", "graded", "student 1009"),
    ]
    # a second run into the same output folder skips it and reads the same files
    again = grade_batch(make_keys(), students, sub, out, histogram=False)
    assert again.files == (*result.files, FileRecord(f"{out}/", "ignored", "folder not read"))
    assert not (out / "histogram.svg").exists()
