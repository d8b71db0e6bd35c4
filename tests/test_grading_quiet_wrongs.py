"""Ordinary actions that used to grade wrongly without a word (issue 26, grading side), driven through
the command line on a class built in the test: an LMS zip, another assignment's manifest, a repeated
column, browser copy names, and the diagnosis that explains an answer best."""

from __future__ import annotations

import csv
import json
import zipfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from gradekit.cli import main

IDS = ["1", "2", "1001"]


def _assignment(folder: Path, salt: str) -> Path:
    f = folder / f"hw-{salt}.yaml"
    f.write_text(
        f'title: "HW {salt}"\ncourse: MEG373\nsalt: "{salt}"\nproblems:\n  - {{id: ch5-ex5-3, points: 10}}\n',
        encoding="utf-8",
    )
    return f


def _generate(asg_file: Path, ids: list[str], out: Path) -> list:
    """The keys and manifest `generate` writes (keys.json, manifest.json), without the PDFs."""
    from gradekit import frozen
    from gradekit.assignment import class_keys, load_assignment, manifest, seeds_of

    asg = load_assignment(asg_file)
    keys, variants = class_keys(asg, ids)
    text = frozen.dumps(keys)
    out.mkdir()
    (out / "keys.json").write_text(text, encoding="utf-8")
    seeds = {s: seeds_of(asg, s, {label: v.redraw for label, v in variants[s].items()}) for s in ids}
    (out / "manifest.json").write_text(json.dumps(manifest(asg, ids, seeds, text)), encoding="utf-8")
    return keys


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    root = tmp_path_factory.mktemp("quiet")
    asg = _assignment(root, "a")
    other = _assignment(root, "b")
    with open(root / "roster.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["student_id", "name"])
        w.writerows([[sid, f"Student {sid}"] for sid in IDS])
    keys = _generate(asg, IDS, root / "gen")
    _generate(other, IDS, root / "gen-b")
    return root, asg, keys


def _grade(root: Path, asg: Path, subs: Path, out: Path, manifest: Path | None = None):
    args = ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions", str(subs), "--out", str(out),
            "--manifest", str(manifest or root / "gen" / "manifest.json")]
    return CliRunner().invoke(main, args)


def _rows(keys, sid: str, scale: float = 1.0) -> list[str]:
    return [f"{sid},{e.key},{e.value * scale:.6g},{e.unit}" for e in keys if e.student_id == sid]


def _grades(out: Path) -> dict[str, str]:
    with open(out / "grades.csv", newline="", encoding="utf-8") as f:
        return {r["student_id"]: r["percent"] for r in csv.DictReader(f)}


def test_an_lms_zip_grades_as_its_folder(course, tmp_path):
    """`--submissions` takes the zip an LMS gives as it is: the same grades as the folder unzipped."""
    root, asg, keys = course
    subs = tmp_path / "subs"
    subs.mkdir()
    for i, sid in enumerate(IDS):
        lines = ["student_id,key,value,unit", *_rows(keys, sid, 1.0 if i != 1 else 1.2)]
        (subs / f"{sid}_answers.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    with zipfile.ZipFile(tmp_path / "all.zip", "w") as z:
        for f in sorted(subs.iterdir()):
            z.write(f, f"submissions/{f.name}")
    folder = _grade(root, asg, subs, tmp_path / "from-folder")
    zipped = _grade(root, asg, tmp_path / "all.zip", tmp_path / "from-zip")
    assert folder.exit_code == 0 and zipped.exit_code == 0, zipped.output
    assert _grades(tmp_path / "from-zip") == _grades(tmp_path / "from-folder")
    assert float(_grades(tmp_path / "from-zip")["1"]) == 100.0
    assert float(_grades(tmp_path / "from-zip")["2"]) < 100.0
    report = (tmp_path / "from-zip" / "report.md").read_text(encoding="utf-8")
    assert "gradekit-submissions-" not in report  # the zip's name, not the temporary folder, is shown


def test_another_assignments_manifest_is_refused_naming_both(course, tmp_path):
    root, asg, keys = course
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1.csv").write_text("\n".join(["student_id,key,value,unit", *_rows(keys, "1")]) + "\n", encoding="utf-8")
    result = _grade(root, asg, subs, tmp_path / "out", root / "gen-b" / "manifest.json")
    assert result.exit_code == 1
    message = result.output.strip().splitlines()[-1]
    assert "salt 'a'" in message and "salt 'b'" in message and "manifest.json" in message
    assert "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_a_repeated_wide_column_keeps_the_first_and_says_so(course, tmp_path):
    root, asg, keys = course
    mine = [e for e in keys if e.student_id == "1001"]
    first = mine[0]
    header = ["student_id", *(e.key for e in mine), first.key]
    values = ["1001", *(f"{e.value:.6g}" for e in mine), f"{first.value * 3:.6g}"]
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1001.csv").write_text(",".join(header) + "\n" + ",".join(values) + "\n", encoding="utf-8")
    result = _grade(root, asg, subs, tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert float(_grades(tmp_path / "out")["1001"]) == 100.0  # the first column counts
    feedback = (tmp_path / "out" / "feedback" / "1001.md").read_text(encoding="utf-8")
    assert f"expected each key once, got {first.key!r} again" in feedback.replace("\\", "")


def test_browser_copy_counters_name_no_student(course, tmp_path):
    """`answers (1).csv` and `answers (2).csv` from a browser's downloads are not students 1 and 2, and
    `001.csv` is not student 1: a number in a file name names a student only as written."""
    root, asg, keys = course
    subs = tmp_path / "subs"
    subs.mkdir()
    header = "student_id,key,value,unit"
    (subs / "answers (1).csv").write_text("\n".join([header, *_rows(keys, "1001")]) + "\n", encoding="utf-8")
    (subs / "answers (2).csv").write_text("\n".join([header, *_rows(keys, "2")]) + "\n", encoding="utf-8")
    (subs / "001.csv").write_text("\n".join([header, *_rows(keys, "1001")]) + "\n", encoding="utf-8")
    result = _grade(root, asg, subs, tmp_path / "out")
    assert result.exit_code == 0, result.output
    grades = _grades(tmp_path / "out")
    assert float(grades["1001"]) == 100.0  # by the id column inside, the file names naming no one
    assert float(grades["2"]) == 100.0
    assert grades["1"] in ("", "0", "0.0")  # nobody's file


def test_each_catalogued_mistake_is_named_for_its_own_value_on_every_problem(tmp_path):
    """A wrong answer equal to one catalogued mistake's value is diagnosed as that mistake (or one with
    the same value, for a direction the same direction), on every problem of the bank: a ×1000 unit slip
    of a torque is a unit slip even where the static answer's band is wide enough to hold it too."""
    from gradekit.assignment import class_keys, load_assignment
    from gradekit.bank.registry import load_bank
    from gradekit.grading import diagnose, generic_mistakes

    items = "".join(f"  - {{id: {pid}, points: 1, label: q{i}}}\n" for i, pid in enumerate(sorted(load_bank())))
    f = tmp_path / "all.yaml"
    f.write_text(f'title: all\ncourse: MEG373\nsalt: "order"\nproblems:\n{items}', encoding="utf-8")
    keys, _ = class_keys(load_assignment(f), ["s1"])
    checked = 0
    for e in keys:
        named = {m.name for m in e.mistakes}
        for m in (*e.mistakes, *(g for g in generic_mistakes(e) if g.name not in named)):
            if m.value == e.value:
                continue
            found = diagnose(e, m.value)
            # the same value, for a direction the same modulo a full turn (−30° is 330°)
            assert found is not None and abs(float(e.tolerance.difference(found.value, m.value))) <= 1e-12 * abs(
                m.value), (e.key, m.name)
            checked += 1
    assert checked > 200


def test_partial_credit_in_the_wider_band_the_assignment_sets(course, tmp_path):
    """`partial_credit: {within: 3, credit: 0.5}`: an answer 2 bands off earns half its points and its
    feedback says which band it fell in; 5 bands off earns nothing; the key itself keeps 100 %."""
    root, _, keys = course
    asg = tmp_path / "hw.yaml"
    asg.write_text((root / "hw-a.yaml").read_text(encoding="utf-8") + "partial_credit: {within: 3, credit: 0.5}\n",
                   encoding="utf-8")
    mine = [e for e in keys if e.student_id == "1001" and not e.tolerance.period and e.value]
    near, far = mine[0], mine[1]
    rows = []
    for e in (k for k in keys if k.student_id == "1001"):
        value = e.value
        if e is near:
            value = e.value + 2 * e.tolerance.band(e.value) * (1 if e.value > 0 else -1)
        elif e is far:
            value = e.value + 5 * e.tolerance.band(e.value) * (1 if e.value > 0 else -1)
        rows.append(f"1001,{e.key},{value!r},{e.unit}")
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1001.csv").write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n", encoding="utf-8")
    result = CliRunner().invoke(main, ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions",
                                       str(subs), "--out", str(tmp_path / "out"), "--manifest",
                                       str(root / "gen" / "manifest.json")])
    assert result.exit_code == 0, result.output
    total = sum(e.points for e in keys if e.student_id == "1001")
    expected = 100 * (total - near.points / 2 - far.points) / total
    assert float(_grades(tmp_path / "out")["1001"]) == pytest.approx(expected, abs=0.051)
    feedback = (tmp_path / "out" / "feedback" / "1001.md").read_text(encoding="utf-8").replace("\\", "")
    near_row = next(line for line in feedback.splitlines() if line.startswith(f"| {near.key} |"))
    far_row = next(line for line in feedback.splitlines() if line.startswith(f"| {far.key} |"))
    assert "partial credit" in near_row and "inside the partial-credit band" in near_row
    assert "| wrong |" in far_row and "partial" not in far_row


@pytest.mark.parametrize(
    "keys, expected",
    [({}, "expected keys: {file, sha256}"), ({"file": "/etc/passwd", "sha256": "0" * 64}, "a file beside the manifest"),
     ({"file": "../keys.json", "sha256": "0" * 64}, "a file beside the manifest")],
)
def test_a_manifest_whose_keys_entry_is_empty_or_points_elsewhere_is_refused(course, tmp_path, keys, expected):
    """`"keys": {}` must not grade against recomputed keys without a word, and keys.file must not leave
    the manifest's folder."""
    root, asg, _ = course
    gen = tmp_path / "gen"
    gen.mkdir()
    data = json.loads((root / "gen" / "manifest.json").read_text(encoding="utf-8"))
    data["keys"] = keys
    (gen / "manifest.json").write_text(json.dumps(data), encoding="utf-8")
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1.csv").write_text("student_id,key,value,unit\n", encoding="utf-8")
    result = _grade(root, asg, subs, tmp_path / "out", gen / "manifest.json")
    assert result.exit_code == 1
    assert expected in result.output and "manifest.json" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "out").exists()


@pytest.mark.parametrize("title", ["Homework 5: $x^$", "the $$ question", "($5 late fee, $5 early)"])
def test_a_title_with_dollar_signs_is_text_everywhere(course, tmp_path, title):
    """A title that mathtext cannot parse used to crash grade in the histogram after all the work."""
    root, _, keys = course
    asg = tmp_path / "hw.yaml"
    text = (root / "hw-a.yaml").read_text(encoding="utf-8").replace('title: "HW a"', f"title: {json.dumps(title)}")
    asg.write_text(text, encoding="utf-8")
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1.csv").write_text("\n".join(["student_id,key,value,unit", *_rows(keys, "1")]) + "\n", encoding="utf-8")
    result = _grade(root, asg, subs, tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "histogram.svg").stat().st_size > 1000
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert title.replace("$", "") in report.replace("\\", "").replace("$", "")


def test_grade_ends_with_what_needs_attention_and_strict_exits_non_zero(course, tmp_path, caplog):
    """'graded 6 of 6' for a class where files could not be read hid them: the console names each file
    and student that needs a look, and --strict turns them into exit 1 (the outputs still written)."""
    root, asg, keys = course
    subs = tmp_path / "subs"
    subs.mkdir()
    header = "student_id,key,value,unit"
    rows = _rows(keys, "1")
    rows[0] = rows[0].rsplit(",", 2)[0] + ",abc," + rows[0].rsplit(",", 1)[1]
    (subs / "1.csv").write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    (subs / "2.csv").write_bytes(b"\x00\x01\x02binary\xff")
    (subs / "stranger.csv").write_text("\n".join([header, "9999,p1.T,1,N*m"]) + "\n", encoding="utf-8")
    plain = _grade(root, asg, subs, tmp_path / "out")
    assert plain.exit_code == 0, plain.output
    said = caplog.text
    assert "graded 2 of 3 students (1 without a submission); 3 need attention" in said
    assert "unreadable file: " in said and "2.csv: file: expected a CSV text file, got binary data" in said
    assert "no student: " in said and "stranger.csv: unknown student '9999'" in said
    assert "answers not read: 1 (Student 1): " in said and "expected a number, got 'abc'" in said
    args = ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions", str(subs), "--out",
            str(tmp_path / "strict"), "--manifest", str(root / "gen" / "manifest.json"), "--strict"]
    strict = CliRunner().invoke(main, args)
    assert strict.exit_code == 1 and "--strict" in strict.output.splitlines()[-1]
    assert (tmp_path / "strict" / "grades.csv").exists()


def test_answers_the_bank_marks_for_hand_checking_are_read_never_judged(tmp_path):
    """An answer no band can grade (`hand_check: true` in the bank, issue 25) is neither passed nor failed:
    its points leave the automatic score, the feedback says the instructor checks it, and the worked
    key's tolerance column says so too."""
    import gradekit

    asg_file = tmp_path / "hw.yaml"
    asg_file.write_text('title: "HW"\ncourse: MEG373\nsalt: "hand"\nproblems:\n  - {id: ch5-ex5-1, points: 10}\n',
                        encoding="utf-8")
    by_hand = {f"p1.{a.key}" for a in gradekit.load_problem("ch5-ex5-1").answers if a.hand_check}
    assert by_hand  # the bank marks some: else this test tests nothing
    (tmp_path / "roster.csv").write_text("student_id,name\n1001,Ada\n", encoding="utf-8")
    keys = _generate(asg_file, ["1001"], tmp_path / "gen")
    subs = tmp_path / "subs"
    subs.mkdir()
    rows = [f"1001,{e.key},{(e.value * 7 if e.key in by_hand else e.value)!r},{e.unit}" for e in keys]
    (subs / "1001.csv").write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n", encoding="utf-8")
    result = CliRunner().invoke(main, ["grade", str(asg_file), "--roster", str(tmp_path / "roster.csv"),
                                       "--submissions", str(subs), "--out", str(tmp_path / "out"), "--manifest",
                                       str(tmp_path / "gen" / "manifest.json")])
    assert result.exit_code == 0, result.output
    with open(tmp_path / "out" / "grades.csv", newline="", encoding="utf-8") as f:
        row = next(csv.DictReader(f))
    assert float(row["max"]) == pytest.approx(sum(e.points for e in keys if e.key not in by_hand))
    assert float(row["percent"]) == 100.0
    feedback = (tmp_path / "out" / "feedback" / "1001.md").read_text(encoding="utf-8").replace("\\", "")
    for key in by_hand:
        line = next(x for x in feedback.splitlines() if x.startswith(f"| {key} |"))
        assert "| checked by hand |" in line and "by hand, of" in line
