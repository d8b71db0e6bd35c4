"""An LMS's "download all submissions" zip, read as the folder it stands for, within limits."""

from __future__ import annotations

import os
import stat
import time
import zipfile
from pathlib import Path

import pytest

from gradekit.errors import GradekitError
from gradekit.grading import grade_batch
from gradekit.grading.archive import Limits, submissions_folder, unpack
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Tolerance

STUDENTS = [Student("1001", "Selam Haile"), Student("1002", "Lars de Vries"), Student("1003", "Zoë Núñez"),
            Student("1004", "Ada Lee")]
VALUES = {"1001": 1.5, "1002": -2.5, "1003": 3.5, "1004": 4.5}
FILES = {  # Moodle's participant folders, Canvas's names (one resubmitted), a plain file
    "Selam Haile_501_assignsubmission_file_/answers.csv": ("1001", 1.5),
    "Zoë Núñez_502_assignsubmission_file_/answers.csv": ("1003", 3.0),
    "vrieslarsde_4242_9001_answers.csv": ("1002", 2.5),  # wrong sign
    "vrieslarsde_4242_9007_answers-1.csv": ("1002", -2.5),  # the newer one: graded
    "1004.csv": ("1004", 4.5),
}


def make_class(root: Path) -> tuple[Path, Path]:
    """The submissions as a folder and as the zip an LMS would give of it (the same times)."""
    folder = root / "unzipped"
    with zipfile.ZipFile(root / "submissions.zip", "w", zipfile.ZIP_DEFLATED) as z:
        for i, (name, (sid, value)) in enumerate(FILES.items()):
            path = folder / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(f"student_id,key,value,unit\n{sid},p1.T,{value},N*m\n", encoding="utf-8")
            stamp = time.mktime((2026, 11, 20, 10, i, 0, 0, 0, -1))
            os.utime(path, (stamp, stamp))
            z.write(path, name)
    return folder, root / "submissions.zip"


def keys() -> list[KeyEntry]:
    return [KeyEntry(sid, "p1", "p1.T", v, "N*m", Tolerance(rel=0.01), 2.0) for sid, v in VALUES.items()]


def test_a_zip_grades_as_the_folder_it_was_made_from(tmp_path: Path) -> None:
    folder, zipped = make_class(tmp_path)
    from_folder = grade_batch(keys(), STUDENTS, folder, tmp_path / "out-folder", assignment_title="HW")
    with submissions_folder(zipped) as unzipped:
        assert unzipped != zipped and unzipped.is_dir()
        from_zip = grade_batch(keys(), STUDENTS, unzipped, tmp_path / "out-zip", assignment_title="HW")
    assert not unzipped.exists()  # the temporary folder is gone after the block
    assert [g.total for g in from_zip.grades] == [g.total for g in from_folder.grades] == [2, 2, 0, 2]
    for name in ("grades.csv", "canvas.csv", "moodle.csv"):
        assert (tmp_path / "out-zip" / name).read_bytes() == (tmp_path / "out-folder" / name).read_bytes()
    for page in (tmp_path / "out-folder" / "feedback").iterdir():  # feedback names no folder of the disk
        assert (tmp_path / "out-zip" / "feedback" / page.name).read_bytes() == page.read_bytes()
    graded = next(g for g in from_zip.grades if g.student.student_id == "1002").submission.path
    assert graded.endswith("vrieslarsde_4242_9007_answers-1.csv")  # the newer file, by the zip's times


def test_a_folder_is_used_as_it_is(tmp_path: Path) -> None:
    with submissions_folder(tmp_path) as folder:
        assert folder == tmp_path
    assert tmp_path.is_dir()


def bomb(path: Path, size: int) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("a_1_assignsubmission_file_/answers.csv", b"0" * size)
    return path


def test_a_zip_bomb_is_refused_with_one_line(tmp_path: Path) -> None:
    zipped = bomb(tmp_path / "bomb.zip", 20_000_000)  # 20 MB of one byte: packs about 1000 times
    with pytest.raises(GradekitError) as info, submissions_folder(zipped):
        pass
    message = info.value.format_message()
    assert message.startswith(f"{zipped}: expected a zip that unpacks at most 200 times its size, got 20000000 bytes")
    assert "\n" not in message


def test_limits_on_count_size_and_depth(tmp_path: Path) -> None:
    zipped = tmp_path / "many.zip"
    with zipfile.ZipFile(zipped, "w") as z:
        for i in range(4):
            z.writestr(f"{i}.csv", "student_id,key,value,unit\n")
    with pytest.raises(GradekitError, match=r"many\.zip: expected at most 3 files in the zip, got 4$"):
        unpack(zipped, tmp_path / "x", Limits(files=3))
    with pytest.raises(GradekitError, match=r"expected at most 100 bytes unpacked, got \d+ or more"):
        unpack(zipped, tmp_path / "y", Limits(total_bytes=100, ratio=1e9))
    deep = tmp_path / "deep.zip"
    with zipfile.ZipFile(deep, "w") as z:
        z.writestr("/".join("abcdefghij") + "/x.csv", "1")
    with pytest.raises(GradekitError, match=r"deep\.zip: a/b/c/d/e/f/g/h/i/j/x\.csv: expected at most 8 folders deep"):
        unpack(deep, tmp_path / "z")


def test_a_zip_that_declares_less_than_it_holds_is_refused(tmp_path: Path) -> None:
    zipped = bomb(tmp_path / "liar.zip", 5_000)
    data = bytearray(zipped.read_bytes())
    for signature, offset in ((b"PK\x03\x04", 22), (b"PK\x01\x02", 24)):  # the uncompressed size fields
        at = data.find(signature)
        data[at + offset: at + offset + 4] = (10).to_bytes(4, "little")
    zipped.write_bytes(bytes(data))
    with pytest.raises(GradekitError, match=r"liar\.zip: a_1_assignsubmission_file_/answers\.csv: expected a readable"):
        unpack(zipped, tmp_path / "out")


@pytest.mark.parametrize("name", ["../evil.csv", "/abs.csv", "C:\\evil.csv", "a/../../evil.csv", "..\\evil.csv"])
def test_no_member_writes_outside_the_folder(tmp_path: Path, name: str) -> None:
    zipped = tmp_path / "escape.zip"
    with zipfile.ZipFile(zipped, "w") as z:
        z.writestr("ok.csv", "1")
        z.writestr(name, "2")
    target = tmp_path / "deep" / "out"
    target.mkdir(parents=True)
    with pytest.raises(GradekitError, match="expected a file name inside the zip's folder, got a path that leaves it"):
        unpack(zipped, target)
    assert sorted(p.name for p in tmp_path.rglob("*evil*")) == []


def test_links_and_folders_in_a_zip_are_not_written(tmp_path: Path) -> None:
    zipped = tmp_path / "link.zip"
    with zipfile.ZipFile(zipped, "w") as z:
        link = zipfile.ZipInfo("passwd.csv")
        link.create_system = 3
        link.external_attr = (stat.S_IFLNK | 0o777) << 16
        z.writestr(link, "/etc/passwd")
        z.writestr("folder/", "")
        z.writestr("folder/1001.csv", "x")
    written = unpack(zipped, tmp_path / "out")
    assert written == [tmp_path / "out" / "folder" / "1001.csv"]
    assert not (tmp_path / "out" / "passwd.csv").exists()


def test_a_file_that_is_no_zip_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "answers.csv"
    path.write_text("student_id,key,value,unit\n")
    with pytest.raises(GradekitError, match=r"answers\.csv: expected a folder of submissions or an LMS's zip"), \
            submissions_folder(path):
        pass
    broken = tmp_path / "broken.zip"
    broken.write_bytes(b"PK\x03\x04" + b"\x00" * 40)
    with pytest.raises(GradekitError, match=r"broken\.zip: expected a zip file, got one that cannot be read"):
        unpack(broken, tmp_path / "o")


def test_the_cli_grades_an_lms_zip_as_its_folder_and_refuses_a_bomb(tmp_path: Path) -> None:
    """`gradekit grade --submissions` given the zip as Moodle and Canvas name its files (participant
    folders old and new, Canvas names with LATE and a resubmission): the folder's grades, LMS imports
    and feedback, byte for byte; a zip bomb ends the command with one line."""
    from click.testing import CliRunner

    from gradekit.cli import main

    (tmp_path / "hw.yaml").write_text(
        "title: HW 1\ncourse: MEG373\nsalt: zip-test\nproblems:\n  - {id: ch5-ex5-1, points: 10}\n", encoding="utf-8")
    (tmp_path / "roster.csv").write_text(
        "student_id,name,email\n1001,Selam Haile,s@uni.edu\n1002,Lars de Vries,l@uni.edu\n1003,Ada Lee,a@uni.edu\n",
        encoding="utf-8")
    from gradekit.assignment import keys_for, load_assignment, student_variant

    asg = load_assignment(tmp_path / "hw.yaml")
    item = asg.items[0]
    values = {sid: keys_for(asg, item, sid, student_variant(asg, item, sid), with_mistakes=False)
              for sid in ("1001", "1002", "1003")}
    names = {
        "Selam Haile_501_assignsubmission_file_/answers.csv": ("1001", 1.0),
        "Lars de Vries_502_assignsubmission_file/answers.csv": ("1002", 1.3),  # Moodle 4.1: no trailing "_"
        "leeada_late_777_9001_answers.csv": ("1003", -1.0),
        "leeada_late_777_9002_answers-1.csv": ("1003", 1.0),  # the resubmission: newer
    }
    folder = tmp_path / "download"
    with zipfile.ZipFile(tmp_path / "download.zip", "w", zipfile.ZIP_DEFLATED) as z:
        for i, (name, (sid, scale)) in enumerate(names.items()):
            path = folder / name
            path.parent.mkdir(parents=True, exist_ok=True)
            rows = [f"{sid},{e.key},{e.value * scale:.6g},{e.unit}" for e in values[sid]]
            path.write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n", encoding="utf-8")
            stamp = time.mktime((2026, 11, 20, 10, i, 0, 0, 0, -1))
            os.utime(path, (stamp, stamp))
            z.write(path, name)
    runner = CliRunner()

    def grade(submissions: Path, out: str):
        return runner.invoke(main, ["grade", str(tmp_path / "hw.yaml"), "--roster", str(tmp_path / "roster.csv"),
                                    "--submissions", str(submissions), "--out", str(tmp_path / out)])

    plain, zipped = grade(folder, "from-folder"), grade(tmp_path / "download.zip", "from-zip")
    assert plain.exit_code == 0 and zipped.exit_code == 0, zipped.output
    percents = (tmp_path / "from-zip" / "grades.csv").read_text(encoding="utf-8").splitlines()[1:]
    assert [row.rsplit(",", 1)[-1] for row in percents] == ["100.0", "0.0", "100.0"]  # 1002 is 30 % off
    for name in ("grades.csv", "canvas.csv", "moodle.csv"):
        assert (tmp_path / "from-zip" / name).read_bytes() == (tmp_path / "from-folder" / name).read_bytes()
    for page in (tmp_path / "from-folder" / "feedback").iterdir():
        assert (tmp_path / "from-zip" / "feedback" / page.name).read_bytes() == page.read_bytes()
    canvas = (tmp_path / "from-zip" / "canvas.csv").read_text(encoding="utf-8").splitlines()
    assert canvas[3].startswith("Ada Lee,777,1003,")  # her Canvas user id, from the name Canvas gave her file
    bomb(tmp_path / "bomb.zip", 20_000_000)
    refused = grade(tmp_path / "bomb.zip", "from-bomb")
    assert refused.exit_code == 1 and "Traceback" not in refused.output
    assert refused.output.strip().splitlines() == [
        f"Error: {tmp_path / 'bomb.zip'}: expected a zip that unpacks at most 200 times its size, got "
        + refused.output.split("got ", 1)[1].strip()]
