"""Answers checked by hand, round trip: `grade` lists them in OUT/hand.csv, the instructor fills its points
column, `grade --hand` puts those points into the scores, and points given are never blanked by a later run."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from click.testing import CliRunner

import gradekit
from gradekit.assignment import class_keys, load_assignment
from gradekit.cli import main

IDS = ["1001", "1002"]


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """An assignment of ch5-ex5-1 (the bank checks F03 and T by hand), two students, each answering every
    key right (the answers checked by hand too)."""
    root = tmp_path_factory.mktemp("hand")
    asg = root / "hw.yaml"
    asg.write_text('title: "HW"\ncourse: MEG373\nsalt: "hand"\nproblems:\n  - {id: ch5-ex5-1, points: 10}\n',
                   encoding="utf-8")
    (root / "roster.csv").write_text("student_id,name\n1001,Ada\n1002,Grace\n", encoding="utf-8")
    keys, _ = class_keys(load_assignment(asg), IDS)
    subs = root / "subs"
    subs.mkdir()
    for sid in IDS:
        rows = [f"{sid},{e.key},{e.value!r},{e.unit}" for e in keys if e.student_id == sid]
        (subs / f"{sid}.csv").write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n", encoding="utf-8")
    by_hand = {f"p1.{a.key}" for a in gradekit.load_problem("ch5-ex5-1").answers if a.hand_check}
    assert by_hand  # the bank marks some: else these tests test nothing
    return root, asg, keys, by_hand


def _grade(course, out: Path, *more: str):
    root, asg, _, _ = course
    return CliRunner().invoke(main, ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions",
                                     str(root / "subs"), "--out", str(out), *more])


def _rows(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _write(path: Path, rows: list[dict]) -> None:
    """Save hand.csv rows, as an instructor's spreadsheet does."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def test_the_worklist_lists_every_answer_checked_by_hand(course, tmp_path):
    _, _, keys, by_hand = course
    result = _grade(course, tmp_path / "out")
    assert result.exit_code == 0, result.output
    rows = _rows(tmp_path / "out" / "hand.csv")
    expected = {(e.student_id, e.key): e for e in keys if e.key in by_hand}
    assert {(r["student_id"], r["key"]) for r in rows} == set(expected)
    for r in rows:
        e = expected[r["student_id"], r["key"]]
        assert float(r["key_value"]) == pytest.approx(e.value, rel=1e-5)
        assert float(r["read_as"]) == pytest.approx(e.value, rel=1e-5)  # each student answered the key
        assert float(r["worth"]) == e.points and r["points"] == ""
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert f"{len(expected)} answer(s) to check by hand" in report
    for key in by_hand:  # never "0 % right": no band judged them
        assert f"| {key.replace('_', chr(92) + '_')} | by hand: points given 0 of 2 |" in report
    grades = {r["student_id"]: r for r in _rows(tmp_path / "out" / "grades.csv")}
    worth = sum(e.points for e in keys if e.student_id == "1001" and e.key not in by_hand)
    assert float(grades["1001"]["max"]) == pytest.approx(worth)  # pending: in neither points nor maximum


def test_points_given_by_hand_enter_the_score_and_stay(course, tmp_path):
    _, _, keys, by_hand = course
    out = tmp_path / "out"
    assert _grade(course, out).exit_code == 0
    rows = _rows(out / "hand.csv")
    given = {}
    for r in rows:  # 1001: each answer checked by hand earns half; 1002 not checked yet
        if r["student_id"] == "1001":
            r["points"] = f"{float(r['worth']) / 2:g}"
            given[r["key"]] = float(r["worth"]) / 2
    _write(out / "hand.csv", rows)
    result = _grade(course, out, "--hand", str(out / "hand.csv"))  # the file in OUT itself: read, then rewritten
    assert result.exit_code == 0, result.output
    grades = {r["student_id"]: r for r in _rows(out / "grades.csv")}
    mine = [e for e in keys if e.student_id == "1001"]
    assert float(grades["1001"]["max"]) == pytest.approx(sum(e.points for e in mine))
    assert float(grades["1001"]["total"]) == pytest.approx(
        sum(e.points for e in mine if e.key not in by_hand) + sum(given.values()))
    theirs = [e for e in keys if e.student_id == "1002"]
    assert float(grades["1002"]["max"]) == pytest.approx(sum(e.points for e in theirs if e.key not in by_hand))
    kept = {(r["student_id"], r["key"]): r["points"] for r in _rows(out / "hand.csv")}
    assert all(float(kept["1001", k]) == v for k, v in given.items())
    assert all(kept["1002", k] == "" for k in by_hand)
    feedback = (out / "feedback" / "1001.md").read_text(encoding="utf-8").replace("\\", "")
    for key, points in given.items():
        line = next(x for x in feedback.splitlines() if x.startswith(f"| {key} |"))
        worth = next(e.points for e in mine if e.key == key)
        assert "| checked by hand |" in line and f"| {points:g}/{worth:g} |" in line


def _fill(path: Path, points: dict[tuple[str, str], str]) -> None:
    """Fill the points column of the hand.csv at *path*, as an instructor does in a spreadsheet."""
    rows = _rows(path)
    for r in rows:
        r["points"] = points.get((r["student_id"], r["key"]), r["points"])
    _write(path, rows)


def _graded_and_filled(course, out: Path, sid: str, points: str) -> str:
    """Grade into *out*, then give *sid*'s first answer checked by hand *points* in OUT/hand.csv; its key."""
    assert _grade(course, out).exit_code == 0
    key = sorted(course[3])[0]
    _fill(out / "hand.csv", {(sid, key): points})
    return key


def test_points_filled_in_the_output_folder_are_read_back_never_blanked(course, tmp_path):
    _, _, keys, by_hand = course
    out = tmp_path / "out"
    key = _graded_and_filled(course, out, "1002", "0")
    result = _grade(course, out)  # the same command again, no --hand
    assert result.exit_code == 0, result.output
    kept = {(r["student_id"], r["key"]): r["points"] for r in _rows(out / "hand.csv")}
    assert kept["1002", key] == "0"
    grades = {r["student_id"]: r for r in _rows(out / "grades.csv")}
    theirs = [e for e in keys if e.student_id == "1002"]
    worth = next(e.points for e in theirs if e.key == key)
    assert float(grades["1002"]["max"]) == pytest.approx(sum(e.points for e in theirs if e.key not in by_hand) + worth)
    assert float(grades["1002"]["total"]) == pytest.approx(sum(e.points for e in theirs if e.key not in by_hand))


def test_points_given_to_an_answer_since_changed_are_not_used(course, tmp_path):
    """A student hands in a new file after the instructor gave points: those points were for the old answer."""
    root, asg, keys, by_hand = course
    out = tmp_path / "out"
    key = _graded_and_filled(course, out, "1001", "1")
    subs = tmp_path / "subs"
    subs.mkdir()
    for sid in IDS:  # 1001 now writes twice the key for that answer; 1002 as before
        text = (root / "subs" / f"{sid}.csv").read_text(encoding="utf-8")
        if sid == "1001":
            e = next(x for x in keys if x.student_id == sid and x.key == key)
            text = text.replace(f"{sid},{key},{e.value!r},", f"{sid},{key},{2 * e.value!r},")
        (subs / f"{sid}.csv").write_text(text, encoding="utf-8")
    res = gradekit.grade(asg, root / "roster.csv", subs, out)
    row = next(r for r in _rows(out / "hand.csv") if (r["student_id"], r["key"]) == ("1001", key))
    assert row["points"] == "" and "1 point(s) were given for" in row["note"] and "check it again" in row["note"]
    grades = {r["student_id"]: r for r in _rows(out / "grades.csv")}
    mine = [e for e in keys if e.student_id == "1001"]
    assert float(grades["1001"]["max"]) == pytest.approx(sum(e.points for e in mine if e.key not in by_hand))
    assert any(line.startswith("check by hand again: ") and f"1001 {key}" in line for line in res.attention())
    assert f"1001 {key}: 1 point(s) were given for" in (out / "report.md").read_text(encoding="utf-8").replace("\\", "")


@pytest.mark.parametrize("edit, field, says", [
    (lambda r, worth: r.update(points=f"{worth + 1:g}"), "points", "expected points from 0 to"),
    (lambda r, worth: r.update(points="-1"), "points", "expected points from 0 to"),
    (lambda r, worth: r.update(points="half"), "points", "got 'half'"),
    (lambda r, worth: r.update(points="1", key="p1.F23"), "key", "graded by its band, not by hand"),
    (lambda r, worth: r.update(points="1", student_id="9999"), "key", "no such student on the roster"),
])
def test_a_wrong_row_is_named_by_file_row_and_column(course, tmp_path, edit, field, says):
    out = tmp_path / "out"
    assert _grade(course, out).exit_code == 0
    rows = _rows(out / "hand.csv")
    edit(rows[1], float(rows[1]["worth"]))
    filled = tmp_path / "filled.csv"
    _write(filled, rows)
    result = _grade(course, out, "--hand", str(filled))
    assert result.exit_code == 1
    last = result.output.strip().splitlines()[-1]
    assert f"filled.csv:3: {field}: " in last and says in last
    assert "Traceback" not in result.output


def test_an_answer_given_twice_is_refused(course, tmp_path):
    out = tmp_path / "out"
    assert _grade(course, out).exit_code == 0
    first = _rows(out / "hand.csv")[0]
    filled = tmp_path / "filled.csv"
    _write(filled, [{**first, "points": "1"}, {**first, "points": "2"}])
    result = _grade(course, out, "--hand", str(filled))
    assert result.exit_code == 1 and "filled.csv:3: key: expected each answer once" in result.output


def test_carried_credit_never_goes_to_an_answer_checked_by_hand(tmp_path):
    """With carried-forward credit, an answer checked by hand stays the instructor's to judge, however well it
    follows from the student's own wrong upstream answers (ch5-quiz-q4: every force, and the input torque
    T_IN the bank checks by hand, scale with the inertia force a student got 10 % too large)."""
    asg = tmp_path / "hw.yaml"
    asg.write_text('title: "HW"\ncourse: MEG373\nsalt: "hand"\nproblems:\n  - {id: ch5-quiz-q4, points: 10}\n',
                   encoding="utf-8")
    (tmp_path / "roster.csv").write_text("student_id,name\n1001,Ada\n", encoding="utf-8")
    by_hand = {f"p1.{a.key}" for a in gradekit.load_problem("ch5-quiz-q4").answers if a.hand_check}
    keys, _ = class_keys(load_assignment(asg), ["1001"])
    subs = tmp_path / "subs"
    subs.mkdir()
    rows = [f"1001,{e.key},{e.value * 1.1!r},{e.unit}" for e in keys]
    (subs / "1001.csv").write_text("\n".join(["student_id,key,value,unit", *rows]) + "\n", encoding="utf-8")
    res = gradekit.grade(asg, tmp_path / "roster.csv", subs, tmp_path / "out", carry_forward=True)
    results = res.grades[0].results
    assert any(r.carried is not None for r in results)  # carrying applies to this student's other answers
    hand = [r for r in results if r.entry.key in by_hand]
    assert hand and all(r.carried is None and r.pending and r.points == 0 for r in hand)
    with open(tmp_path / "out" / "grades.csv", newline="", encoding="utf-8") as f:
        carried = int(next(csv.DictReader(f))["carried"])
    assert carried == sum(r.carried is not None for r in results if r.entry.key not in by_hand)


def test_a_spreadsheet_rewriting_a_number_does_not_make_points_stale(course, tmp_path):
    """Saved from a spreadsheet, an answered cell 1.2e3 may come back as 1200: the same answer, its points kept."""
    out = tmp_path / "out"
    key = _graded_and_filled(course, out, "1001", "1")
    rows = _rows(out / "hand.csv")
    for r in rows:
        if (r["student_id"], r["key"]) == ("1001", key):
            number, unit = r["answered"].split(" [")
            r["answered"] = f"{float(number):.17e} [{unit}"  # the same number, written another way
            assert r["answered"].split(" [")[0] != number
    _write(out / "hand.csv", rows)
    assert _grade(course, out).exit_code == 0
    kept = {(r["student_id"], r["key"]): r for r in _rows(out / "hand.csv")}
    assert kept["1001", key]["points"] == "1" and kept["1001", key]["note"] == ""


@pytest.mark.parametrize("content, says", [
    (b"\x7fELF\x02\x01" + bytes(range(256)) * 4, "expected a student_id column"),
    (b'student_id,key,points\n"' + b"x" * 200_000 + b'"\n', "unreadable CSV (field larger than field limit"),
])
def test_a_file_that_is_no_hand_csv_gets_one_line(course, tmp_path, content, says):
    (tmp_path / "not.csv").write_bytes(content)
    result = _grade(course, tmp_path / "out", "--hand", str(tmp_path / "not.csv"))
    assert result.exit_code == 1 and "Traceback" not in result.output
    last = result.output.strip().splitlines()[-1]
    assert "not.csv" in last and says in last and len(last) < 400


def test_points_given_to_a_student_without_a_file_are_kept(course, tmp_path):
    """An instructor adds a row by hand for a student who handed in on paper: the next run keeps it."""
    root, asg, keys, by_hand = course
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "1001.csv").write_bytes((root / "subs" / "1001.csv").read_bytes())  # 1002 hands in nothing
    out = tmp_path / "out"
    assert CliRunner().invoke(main, ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions",
                                     str(subs), "--out", str(out)]).exit_code == 0
    rows = _rows(out / "hand.csv")
    assert {r["student_id"] for r in rows} == {"1001"}
    key = sorted(by_hand)[0]
    _write(out / "hand.csv", [*rows, {**rows[0], "student_id": "1002", "name": "Grace", "key": key, "answered": "",
                                      "points": "1"}])
    result = CliRunner().invoke(main, ["grade", str(asg), "--roster", str(root / "roster.csv"), "--submissions",
                                       str(subs), "--out", str(out)])
    assert result.exit_code == 0, result.output
    kept = {(r["student_id"], r["key"]): r["points"] for r in _rows(out / "hand.csv")}
    assert kept["1002", key] == "1"
    grades = {r["student_id"]: r for r in _rows(out / "grades.csv")}
    assert float(grades["1002"]["total"]) == 1.0


def test_points_given_survive_a_run_that_does_not_choose_hand_csv(course, tmp_path):
    out = tmp_path / "out"
    key = _graded_and_filled(course, out, "1001", "1")
    result = _grade(course, out, "--exports", "grades")
    assert result.exit_code == 0, result.output
    kept = {(r["student_id"], r["key"]): r["points"] for r in _rows(out / "hand.csv")}
    assert kept["1001", key] == "1"


def test_points_in_the_output_folder_are_not_replaced_by_another_file(course, tmp_path):
    out = tmp_path / "out"
    key = _graded_and_filled(course, out, "1001", "1")
    blank = tmp_path / "blank.csv"
    _write(blank, [{**r, "points": ""} for r in _rows(out / "hand.csv")])
    before = (out / "hand.csv").read_bytes()
    result = _grade(course, out, "--hand", str(blank))
    assert result.exit_code == 1
    last = result.output.strip().splitlines()[-1]
    assert "hand.csv" in last and f"1 only here (first 1001 {key}: 1," in last and "blank.csv" in last
    assert (out / "hand.csv").read_bytes() == before
    _fill(blank, {("1001", key): "1"})  # the same points elsewhere: nothing is lost
    assert _grade(course, out, "--hand", str(blank)).exit_code == 0
