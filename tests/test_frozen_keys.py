"""Keys are computed once, when the sheets are generated, and frozen: grading with the manifest never
re-samples, so a later change of the measured tolerance table changes no grade."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gradekit", *args], cwd=cwd, capture_output=True, text=True)


def _grades(out: Path) -> dict[str, float]:
    with open(out / "grades.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    col = next(c for c in rows[0] if c.lower().startswith("percent") or c.lower() == "percent")
    return {r["student_id"]: float(r[col]) for r in rows}


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("frozen")
    shutil.copytree(ROOT / "problem_bank", tmp / "bank")
    (tmp / "hw.yaml").write_text(
        "title: Frozen\ncourse: MEG373\nsalt: frozen-test\nbank: bank\nproblems:\n  - {id: ch5-ex5-1, points: 3}\n",
        encoding="utf-8",
    )
    (tmp / "roster.csv").write_text("student_id,name\n1001,A\n1002,B\n1003,C\n", encoding="utf-8")
    r = _cli("generate", "hw.yaml", "--roster", "roster.csv", "--out", "gen", "--no-keys", cwd=tmp)
    assert r.returncode == 0, r.stderr
    frozen = json.loads((tmp / "gen" / "keys.json").read_text(encoding="utf-8"))
    tol = frozen["answers"]["p1.F23"]["tolerance"]  # (F03 and T are checked by hand: issue 25)
    subs = tmp / "subs"
    subs.mkdir()
    widest = 0.0
    for sid, rows in frozen["students"].items():
        with open(subs / f"{sid}.csv", "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["student_id", "key", "value", "unit"])
            for key, (value, tol_abs, _m) in rows.items():
                if sid != "1001" and key == "p1.F23":  # 1.5 bands high: outside the frozen band
                    band = max(tol["rel"] * abs(value), tol_abs)
                    widest = max(widest, 3 * band / abs(value))
                    value += 1.5 * band
                w.writerow([sid, key, repr(value), frozen["answers"][key]["unit"]])
    (tmp / "wider_rel").write_text(repr(widest), encoding="utf-8")  # a band that admits them
    return tmp


def test_generate_freezes_every_students_key_with_its_hashes(course):
    manifest = json.loads((course / "gen" / "manifest.json").read_text(encoding="utf-8"))
    frozen = json.loads((course / "gen" / "keys.json").read_text(encoding="utf-8"))
    assert set(frozen["students"]) == {"1001", "1002", "1003"}
    assert manifest["keys"]["file"] == "keys.json" and len(manifest["keys"]["sha256"]) == 64
    assert len(manifest["tolerances_sha256"]) == 64
    keys = {(k["student_id"], k["key"]): float(k["value"]) for k in csv.DictReader((course / "gen" / "key.csv").open())}
    for sid, rows in frozen["students"].items():
        for key, (value, _abs, _mistakes) in rows.items():
            assert value == pytest.approx(keys[(sid, key)], rel=1e-9)


def test_a_changed_tolerance_table_changes_no_grade_with_the_manifest(course):
    args = ("grade", "hw.yaml", "--roster", "roster.csv", "--submissions", "subs", "--manifest", "gen/manifest.json")
    before = _cli(*args, "--out", "g1", cwd=course)
    assert before.returncode == 0, before.stderr
    table = course / "bank" / "_tolerances.yaml"
    original = table.read_text(encoding="utf-8")
    data = yaml.safe_load(original)
    for row in data["ch5-ex5-1"].values():
        row["rel"] = float((course / "wider_rel").read_text())  # a re-derived table with wider bands
    table.write_text(yaml.safe_dump(data), encoding="utf-8")
    try:
        after = _cli(*args, "--out", "g2", cwd=course)
        recomputed = _cli(*args, "--recompute-keys", "--out", "g3", cwd=course)
    finally:
        table.write_text(original, encoding="utf-8")
    assert after.returncode == 0 and recomputed.returncode == 0, after.stderr + recomputed.stderr
    assert "tolerance table (_tolerances.yaml) changed" in after.stderr
    assert "graded against the keys frozen at generation" in after.stderr
    g1, g2, g3 = _grades(course / "g1"), _grades(course / "g2"), _grades(course / "g3")
    assert g1 == g2  # frozen: the same marks
    assert g1["1001"] == pytest.approx(100.0)
    assert g1["1002"] < 100.0 and g1["1003"] < 100.0  # F23 1.5 bands off is outside the frozen band
    assert g3["1002"] == pytest.approx(100.0) and g3["1003"] == pytest.approx(100.0)  # the new, wider band


def test_an_edited_frozen_key_file_is_refused(course):
    bad = course / "tampered"
    shutil.copytree(course / "gen", bad)
    text = (bad / "keys.json").read_text(encoding="utf-8").replace('"1001"', '"1001"', 1)
    doc = json.loads(text)
    first = next(iter(doc["students"]["1001"]))
    doc["students"]["1001"][first][0] *= 2
    (bad / "keys.json").write_text(json.dumps(doc), encoding="utf-8")
    r = _cli("grade", "hw.yaml", "--roster", "roster.csv", "--submissions", "subs", "--manifest",
             "tampered/manifest.json", "--out", "g4", cwd=course)
    assert r.returncode == 1
    assert "keys.json: expected the frozen keys the manifest was written with" in r.stderr


def test_tolerance_floors_compare_answers_of_one_dimension_in_si(tmp_path):
    """An answer in kN beside one in N: the floor's scale is the largest force in SI, expressed in each
    answer's own unit (not the largest raw number, which would make the kN floor 1000 times too wide)."""
    from gradekit.bank.schema import load_problem
    from gradekit.solving.pipeline import published_values, solve_problem

    text = (ROOT / "problem_bank" / "ch5_ex5_1_slider_crank_static.yaml").read_text(encoding="utf-8")
    text = text.replace('{key: F23, of: "F[2,3].mag", unit: N,', '{key: F23, of: "F[2,3].mag", unit: kN,')
    assert "unit: kN" in text
    f = tmp_path / "mixed.yaml"
    f.write_text(text.replace("id: ch5-ex5-1", "id: mixed-units"), encoding="utf-8")
    p = load_problem(f)
    r = solve_problem(p, published_values(p))
    f03, f23 = r.answers["F03"], r.answers["F23"]
    assert (f03.unit, f23.unit) == ("N", "kN")
    largest_newtons = max(abs(f03.value), abs(f23.value) * 1000.0)
    assert f03.scale == pytest.approx(largest_newtons, rel=1e-12)
    assert f23.scale == pytest.approx(largest_newtons / 1000.0, rel=1e-12)
    assert not f23.tolerance.accepts(0.0, f23.value)


def test_the_assignments_feedback_choice_reaches_the_students_files(course):
    """`feedback: band` in the assignment: a wrong answer's feedback says how many tolerances off
    (1.5 bands here: "within twice the tolerance"), never the amount."""
    text = (course / "hw.yaml").read_text(encoding="utf-8") + "feedback: band\n"
    (course / "hw_band.yaml").write_text(text, encoding="utf-8")
    r = _cli("grade", "hw_band.yaml", "--roster", "roster.csv", "--submissions", "subs", "--manifest",
             "gen/manifest.json", "--out", "g5", cwd=course)
    assert r.returncode == 0, r.stderr
    feedback = (course / "g5" / "feedback" / "1002.md").read_text(encoding="utf-8")
    assert "too high, within twice the tolerance" in feedback


def test_every_roster_student_is_graded_once_and_keys_derived_with_progress(course):
    """Without a manifest the keys are derived for the class, problem by problem (reported to the
    progress callback); grades.csv has every roster student exactly once, submission or not."""
    import gradekit

    roster = course / "roster4.csv"
    roster.write_text("student_id,name\n1001,A\n1002,B\n1003,C\n1004,D\n", encoding="utf-8")
    seen = []
    res = gradekit.grade(course / "hw.yaml", roster, course / "subs", course / "g6",
                         progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 1)]
    with open(course / "g6" / "grades.csv", newline="", encoding="utf-8") as f:
        ids = [r["student_id"] for r in csv.DictReader(f)]
    assert sorted(ids) == ["1001", "1002", "1003", "1004"]
    assert res.graded == 3


def _entries():
    from gradekit.solving.keys import KeyEntry, Mistake, Tolerance

    tol = Tolerance("relative", 0.01, abs=0.5, floor=0.001)
    return [
        KeyEntry("1001", "p1", "p1.T", 12.5, "N*m", tol, 2.0, "torque", "ccw+",
                 (Mistake("static-answer", "a static answer", 10.0),)),
        KeyEntry("1001", "p1", "p1.F", -3.0, "N", Tolerance("sigfigs", 0.0, abs=0.25), 1.0, "force"),
        KeyEntry("1002", "p2", "p2.a", 7.0, "m/s^2", tol, 1.0),
        KeyEntry("1002", "p1", "p1.T", 11.0, "N*m", tol, 2.0, "torque", "ccw+"),
    ]


def test_frozen_keys_load_every_students_entries_as_dumped():
    """loads gives each student's entries, equal to the entries dumped, in order."""
    from gradekit import frozen

    keys = _entries()
    loaded = frozen.loads(frozen.dumps(keys), "keys.json")
    assert list(loaded) == ["1001", "1002"] and "1003" not in loaded
    assert loaded["1001"] == keys[:2] and loaded["1002"] == keys[2:]


@pytest.mark.parametrize(
    "row",
    ['["x",0.5,[]]', '[1.0,0.5]', '[1.0,0.5,[["no-such-mistake",2.0]]]', '["nan",0.5,[]]', '[1.0,-0.5,[]]',
     '[1e999,0.5,[]]', '[1.0,0.5,[["static-answer","inf"]]]'],
)
def test_a_malformed_student_entry_names_the_file(row):
    """A value that is not a finite number, a negative tolerance, an unknown mistake: one message naming
    the file (issue 26: keys.json with its hash recomputed must not slip "nan" or a negative band in)."""
    from gradekit import frozen
    from gradekit.errors import GradekitError

    text = frozen.dumps(_entries()).replace('"p2.a":[7.0,0.5,[]]', f'"p2.a":{row}')
    assert row in text
    with pytest.raises(GradekitError, match="expected the frozen keys written by gradekit generate") as e:
        frozen.loads(text, "gen/keys.json")
    assert e.value.path == "gen/keys.json"


@pytest.mark.parametrize("field, bad", [("rel", -1), ("floor", -0.1), ("period", "x"), ("mode", "loose")])
def test_a_malformed_answer_tolerance_is_refused(field, bad):
    import json

    from gradekit import frozen
    from gradekit.errors import GradekitError

    doc = json.loads(frozen.dumps(_entries()))
    doc["answers"]["p1.T"]["tolerance"][field] = bad
    with pytest.raises(GradekitError, match="p1.T tolerance"):
        frozen.loads(json.dumps(doc), "gen/keys.json")


def test_a_corrupt_frozen_key_file_with_its_hash_gives_one_line_naming_it(course):
    """A keys.json whose hash the manifest holds but whose entries are malformed: one line naming
    it, exit 1, nothing written (the entries are built while grading, inside the staged output)."""
    bad = course / "corrupt"
    shutil.copytree(course / "gen", bad)
    doc = json.loads((bad / "keys.json").read_text(encoding="utf-8"))
    first = next(iter(doc["students"]["1002"]))
    doc["students"]["1002"][first] = ["not a number", 0.1, []]
    text = json.dumps(doc)
    (bad / "keys.json").write_text(text, encoding="utf-8")
    manifest = json.loads((bad / "manifest.json").read_text(encoding="utf-8"))
    from gradekit import frozen

    manifest["keys"]["sha256"] = frozen.sha256(text)
    (bad / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    r = _cli("grade", "hw.yaml", "--roster", "roster.csv", "--submissions", "subs", "--manifest",
             "corrupt/manifest.json", "--out", "g-corrupt", cwd=course)
    assert r.returncode == 1
    assert r.stderr.strip().count("\n") == 0, r.stderr
    assert "keys.json" in r.stderr and "expected the frozen keys written by gradekit generate" in r.stderr
    assert not (course / "g-corrupt" / "grades.csv").exists()


def test_a_frozen_key_file_copied_with_windows_line_ends_grades_the_same(course):
    """keys.json read as bytes (hashed and parsed as such) still matches its manifest after a copy
    that turned its line end into CRLF, as the text-mode read before it did."""
    crlf = course / "crlf"
    shutil.copytree(course / "gen", crlf)
    data = (crlf / "keys.json").read_bytes()
    assert data.endswith(b"\n") and b"\r" not in data
    (crlf / "keys.json").write_bytes(data.replace(b"\n", b"\r\n"))
    args = ("grade", "hw.yaml", "--roster", "roster.csv", "--submissions", "subs")
    a = _cli(*args, "--manifest", "gen/manifest.json", "--out", "g-lf", cwd=course)
    b = _cli(*args, "--manifest", "crlf/manifest.json", "--out", "g-crlf", cwd=course)
    assert a.returncode == 0 and b.returncode == 0, (a.stderr, b.stderr)
    assert _grades(course / "g-crlf") == _grades(course / "g-lf")


@pytest.mark.parametrize("bad", [b'{"format":1,"x":NaN}', b'{"format":1,"answers":{"\xff":1}}', b"[1,2"])
def test_frozen_keys_that_are_not_the_json_generate_writes_are_one_clean_error(bad):
    """Not finite numbers, bytes that are not UTF-8, a cut-off file: the one-line error naming the
    file, not a parser's traceback."""
    from gradekit import frozen
    from gradekit.errors import GradekitError

    with pytest.raises(GradekitError, match="expected the frozen keys written by gradekit generate") as e:
        frozen.loads(bad, "gen/keys.json")
    assert e.value.path == "gen/keys.json"
