"""`gradekit grade` writes the exports the assignment or --exports chooses, and canvas.csv names the Canvas
assignment a Canvas gradebook export roster shows."""

from __future__ import annotations

import zipfile
from pathlib import Path

from click.testing import CliRunner

from gradekit.assignment import keys_for, load_assignment, student_variant
from gradekit.cli import main

HEAD = "title: HW 5\ncourse: MEG373\nsalt: wiring\nproblems:\n  - {id: ch5-ex5-3, points: 10}\n"  # (no hand check)
ROSTER = ('Student,ID,SIS User ID,SIS Login ID,Section,HW 4 (311),HW 5 (312)\n'
          '    Points Possible,,,,,10,10\n'
          '"de Vries, Lars",4242,1001,lvries,A,8,\n"Haile, Selam",4243,1002,shaile,A,9,\n')


def course(tmp_path: Path, exports: str = "") -> Path:
    (tmp_path / "hw.yaml").write_text(HEAD + exports, encoding="utf-8")
    (tmp_path / "roster.csv").write_text(ROSTER, encoding="utf-8")
    asg = load_assignment(tmp_path / "hw.yaml")
    item = asg.items[0]
    folders = {"1001": "Lars de Vries_77_assignsubmission_file_", "1002": "Selam Haile_78_assignsubmission_file_"}
    for sid, folder in folders.items():
        rows = [f"{sid},{e.key},{e.value:.6g},{e.unit}"
                for e in keys_for(asg, item, sid, student_variant(asg, item, sid), with_mistakes=False)]
        (tmp_path / "subs" / folder).mkdir(parents=True)
        (tmp_path / "subs" / folder / "answers.csv").write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n",
                                                               encoding="utf-8")
    return tmp_path


def grade(root: Path, *extra: str):
    return CliRunner().invoke(main, ["grade", str(root / "hw.yaml"), "--roster", str(root / "roster.csv"),
                                     "--submissions", str(root / "subs"), "--out", str(root / "out"), *extra])


def test_the_assignment_chooses_the_exports(tmp_path: Path) -> None:
    root = course(tmp_path, "exports: [grades, canvas, moodle-feedback-zip]\n")
    r = grade(root)
    assert r.exit_code == 0, r.output
    written = sorted(p.name for p in (root / "out").iterdir() if not p.name.startswith("."))
    assert written == ["canvas.csv", "grades.csv", "moodle-feedback.zip"]
    canvas = (root / "out" / "canvas.csv").read_text(encoding="utf-8").splitlines()
    assert canvas[0] == "Student,ID,SIS User ID,SIS Login ID,Section,HW 5 (312)"  # the roster's HW 5 column
    assert canvas[1] == "Lars de Vries,4242,1001,lvries,A,10"
    with zipfile.ZipFile(root / "out" / "moodle-feedback.zip") as z:
        assert z.namelist() == ["Lars de Vries_77_assignsubmission_file_/feedback.html",
                                "Selam Haile_78_assignsubmission_file_/feedback.html"]


def test_the_command_line_chooses_over_the_assignment(tmp_path: Path) -> None:
    root = course(tmp_path, "exports: [grades]\n")
    r = grade(root, "--exports", "report,feedback")
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (root / "out").iterdir() if not p.name.startswith(".")) == ["feedback", "report.md"]
    bad = grade(root, "--exports", "report,canvass")
    assert bad.exit_code == 1 and "--exports: expected exports among grades, canvas" in bad.output
    assert "got 'canvass' (did you mean 'canvas'?)" in bad.output


def test_moodle_41_folders_name_their_participant(tmp_path: Path) -> None:
    """Moodle 4.1 and later name a participant's folder without the trailing "_"; its file is the
    participant's even when the file itself names no one."""
    from gradekit.grading import grade_batch
    from gradekit.roster import Student
    from gradekit.solving.keys import KeyEntry, Tolerance

    for name, value in (("Selam Haile_501_assignsubmission_file", 1.5), ("Ada Lee_502_assignsubmission_file_", 2.5)):
        (tmp_path / "subs" / name).mkdir(parents=True)
        (tmp_path / "subs" / name / "answers.csv").write_text(f"key,value,unit\np1.T,{value},N*m\n", encoding="utf-8")
    keys = [KeyEntry("1", "p1", "p1.T", 1.5, "N*m", Tolerance(rel=0.01), 2.0),
            KeyEntry("2", "p1", "p1.T", 2.5, "N*m", Tolerance(rel=0.01), 2.0)]
    result = grade_batch(keys, [Student("1", "Selam Haile"), Student("2", "Ada Lee")], tmp_path / "subs",
                         tmp_path / "out")
    assert sorted((f.status, f.detail) for f in result.files) == [("graded", "student 1"), ("graded", "student 2")]
