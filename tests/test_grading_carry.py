"""Grading with error carried forward (`gradekit grade --carry-forward`, ``carry_forward:`` in the
assignment): a student who misread one input and worked on consistently is credited on every later
answer, the expected answers coming from an independent full solve with the misread input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

import gradekit
from gradekit import frozen
from gradekit.assignment import class_keys, load_assignment, manifest, seeds_of
from gradekit.cli import main
from gradekit.errors import GradekitError
from gradekit.numbers import fmt
from gradekit.solving import carry

PROBLEMS = ("ch5-ex5-3", "ch5-dyn-slider-crank", "s004-case-study")
IDS = ("7001", "7002", "7003")  # misread ω; misread ω and later answers inconsistent; honest


def _assignment(tmp: Path, extra: str = "") -> Path:
    items = "".join(f"  - {{id: {pid}, points: 10}}\n" for pid in PROBLEMS)
    path = tmp / "hw.yaml"
    path.write_text(f"title: Carry\ncourse: MEG373\nsalt: carry-test\n{extra}problems:\n{items}", encoding="utf-8")
    return path


def _misread(v, factor: float = 1.1):
    """The answers of a student who read the crank speed *factor* × too high and solved consistently:
    a full independent solve of their problem at that speed (the geometry unchanged)."""
    p = v.result.problem
    name = p.inputs["omega"]
    return {a.key: a for a in gradekit.solve(p, {**v.values, name: v.values[name] * factor}).answers}


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("carry")
    path = _assignment(tmp)
    (tmp / "roster.csv").write_text("student_id,name\n" + "".join(f"{s},S{s}\n" for s in IDS), encoding="utf-8")
    asg = load_assignment(path)
    keys, variants = class_keys(asg, list(IDS))
    subs = tmp / "subs"
    subs.mkdir()
    expected: dict[str, set[str]] = {}  # the answers of 7001 that carrying must credit
    kinematic: dict[str, set[str]] = {}
    for sid in IDS:
        rows = [["student_id", "key", "value", "unit"]]
        for item in asg.items:
            v = variants[sid][item.label]
            key = {a.key: a for a in v.result.answers}
            mine = _misread(v) if sid != "7003" else key
            deps = carry.dependencies(v.result)
            for k, a in mine.items():
                value = a.value
                later = deps[k].stage not in ("given", "kinematics")
                if sid == "7002" and deps[k].stage in ("forces", "total"):  # ten bands off what the
                    tol = key[k].tolerance  # student's own (misread) kinematics and inertia give
                    value += 10 * max(tol.rel * abs(value), tol.abs)
                rows.append([sid, f"{item.label}.{k}", repr(value), a.unit])
                if sid == "7001":
                    wrong = not key[k].tolerance.accepts(a.value, key[k].value)
                    held = any(h.startswith("inertia[") for h in deps[k].held)  # a link's motion not asked
                    if later and wrong and deps[k].carriable and not held:
                        expected.setdefault(sid, set()).add(f"{item.label}.{k}")
                    if deps[k].stage == "kinematics" and wrong:
                        kinematic.setdefault(sid, set()).add(f"{item.label}.{k}")
        with open(subs / f"{sid}.csv", "w", newline="", encoding="utf-8") as f:
            csv.writer(f).writerows(rows)
    text = frozen.dumps(keys)
    (tmp / "gen").mkdir()
    (tmp / "gen" / "keys.json").write_text(text, encoding="utf-8")
    seeds = {s: seeds_of(asg, s, {label: v.redraw for label, v in variants[s].items()}) for s in IDS}
    (tmp / "gen" / "manifest.json").write_text(json.dumps(manifest(asg, list(IDS), seeds, text)), encoding="utf-8")
    return tmp, path, expected, kinematic


def _run(course, out: str, **kw):
    tmp, path, _, _ = course
    return gradekit.grade(path, tmp / "roster.csv", tmp / "subs", tmp / out, **kw)


def _by_key(res, sid: str):
    g = next(g for g in res.grades if g.student.student_id == sid)
    return g, {r.entry.key: r for r in g.results}


def test_a_misread_crank_speed_is_carried_into_every_later_answer_and_not_the_kinematics(course):
    _, _, expected, kinematic = course
    res = _run(course, "carried", carry_forward=True)
    g, rs = _by_key(res, "7001")
    assert expected["7001"] and kinematic["7001"]
    for problem in PROBLEMS:  # every problem has later answers carried
        label = f"p{PROBLEMS.index(problem) + 1}"
        assert any(k.startswith(label + ".") for k in expected["7001"]), problem
    carried = {k for k, r in rs.items() if r.carried is not None}
    assert carried == expected["7001"]
    for k in carried:
        assert not rs[k].correct and rs[k].points == rs[k].entry.points  # full credit by default
    for k in kinematic["7001"]:
        assert rs[k].points == 0 and rs[k].carried is None
    # F01 of the dynamic slider crank depends on the crank's own inertia, whose motion the problem
    # never asks: it stays exact, so a misread ω is not carried into it
    assert "p2.F01" not in carried and rs["p2.F01"].points == 0


def test_without_the_option_grading_is_unchanged(course):
    plain = _run(course, "plain")
    g, rs = _by_key(plain, "7001")
    assert all(r.carried is None for r in rs.values())
    assert g.total == sum(r.entry.points for r in rs.values() if r.correct)
    carried = _run(course, "carried2", carry_forward=True)
    g2, rs2 = _by_key(carried, "7001")
    gained = sum(rs2[k].points for k in rs2 if rs2[k].carried is not None)
    assert gained > 0 and g2.total == pytest.approx(g.total + gained)
    header = next(csv.reader(open(course[0] / "plain" / "grades.csv", encoding="utf-8")))
    assert "carried" not in header
    # an honest student's marks are the same either way
    assert _by_key(plain, "7003")[0].total == _by_key(carried, "7003")[0].total == 30


def test_later_answers_inconsistent_with_the_students_own_earn_nothing(course):
    """7002 misread ω like 7001 and worked the inertia on consistently, but their forces follow from
    neither the key nor their own inertia: the inertia is carried, no force is."""
    res = _run(course, "carried3", carry_forward=True)
    g, rs = _by_key(res, "7002")
    carried = {k for k, r in rs.items() if r.carried is not None}
    deps = {}
    for item in load_assignment(course[1]).items:
        v = gradekit.sample(item.problem, seed=0)
        deps.update({f"{item.label}.{k}": d for k, d in carry.dependencies(v.result).items()})
    assert carried and all(deps[k].stage == "inertia" for k in carried)
    assert g.total == sum(r.entry.points for r in rs.values() if r.correct or r.carried is not None)


def test_grades_feedback_and_report_say_what_was_carried(course):
    tmp = course[0]
    res = _run(course, "carried4", carry_forward=True)
    count = {sid: sum(r.carried is not None for r in _by_key(res, sid)[0].results) for sid in IDS}
    n = count["7001"]
    assert n and count["7002"] and not count["7003"]
    rows = {r["student_id"]: r for r in csv.DictReader(open(tmp / "carried4" / "grades.csv", encoding="utf-8"))}
    assert {sid: int(rows[sid]["carried"]) for sid in IDS} == count
    md = (tmp / "carried4" / "feedback" / "7001.md").read_text(encoding="utf-8")
    assert md.count("carried forward (full credit)") == n
    assert "consistent with your" in md
    page = (tmp / "carried4" / "feedback" / "7001.html").read_text(encoding="utf-8")
    assert page.count('class="carried"') == n
    report = (tmp / "carried4" / "report.md").read_text(encoding="utf-8")
    assert "## Carried forward" in report and f"{n + count['7002']} answers of 2 students" in report
    # the one later answer of these problems only partly carried, with why
    assert "| p2.F01 | carried with the inertia of link 1 kept exact (the problem asks none of its motion) |" in report


def test_the_feedback_quotes_the_students_own_values_not_the_key(course):
    tmp = course[0]
    res = _run(course, "carried5", carry_forward=True)
    g, rs = _by_key(res, "7001")
    md = (tmp / "carried5" / "feedback" / "7001.md").read_text(encoding="utf-8")
    line = next(x for x in md.splitlines() if x.startswith("| p1.T |"))
    assert rs["p1.T"].carried is not None and "consistent with your" in line
    shown = line.split("consistent with your", 1)[1]
    for k in ("Fi2", "C2", "Fi3", "C3"):  # their inertia answers (10 % ω high), named with their own values
        mine, key = rs[f"p1.{k}"].value, rs[f"p1.{k}"].entry.value
        assert f"{k} = {fmt(mine, 3)}" in shown and f"{k} = {fmt(key, 3)}" not in shown


def test_frozen_keys_carry_the_same(course):
    tmp = course[0]
    a = _run(course, "carried6", carry_forward=True)
    b = _run(course, "carried7", carry_forward=True, manifest=tmp / "gen" / "manifest.json")
    for sid in IDS:
        assert _by_key(a, sid)[0].total == pytest.approx(_by_key(b, sid)[0].total)
        assert {k for k, r in _by_key(a, sid)[1].items() if r.carried} == {
            k for k, r in _by_key(b, sid)[1].items() if r.carried}


def test_the_assignment_sets_the_credit_and_can_turn_it_off(course, tmp_path):
    tmp = course[0]
    half = _assignment(tmp_path, "carry_forward: {credit: 0.5}\n")
    res = gradekit.grade(half, tmp / "roster.csv", tmp / "subs", tmp_path / "half")
    g, rs = _by_key(res, "7001")
    carried = [r for r in rs.values() if r.carried is not None]
    assert carried and all(r.points == pytest.approx(0.5 * r.entry.points) for r in carried)
    assert "carried forward (credit 50 %)" in (tmp_path / "half" / "feedback" / "7001.md").read_text(encoding="utf-8")
    off = _assignment(tmp_path, "carry_forward: false\n")
    res = gradekit.grade(off, tmp / "roster.csv", tmp / "subs", tmp_path / "off", carry_forward=True)
    assert all(r.carried is None for r in _by_key(res, "7001")[0].results)


@pytest.mark.parametrize("value, expected", [
    ("2", "expected true, false or a mapping {credit: 0.5}, got 2"),
    ("{credit: 1.5}", "expected a fraction of the points from 0 to 1, got 1.5"),
    ("{credit: 0}", "expected a number greater than 0, got 0"),
    ("{share: 0.5}", "share"),
])
def test_a_bad_carry_forward_names_the_line_and_field(tmp_path, value, expected):
    path = _assignment(tmp_path, f"carry_forward: {value}\n")
    with pytest.raises(GradekitError) as exc:
        load_assignment(path)
    text = str(exc.value)
    assert "carry_forward" in text and expected in text and "hw.yaml" in text


def test_the_command_has_the_option(course):
    tmp = course[0]
    r = CliRunner().invoke(main, ["-q", "grade", str(tmp / "hw.yaml"), "--roster", str(tmp / "roster.csv"),
                                  "--submissions", str(tmp / "subs"), "--out", str(tmp / "cli"), "--carry-forward"])
    assert r.exit_code == 0, r.output
    rows = {r["student_id"]: r for r in csv.DictReader(open(tmp / "cli" / "grades.csv", encoding="utf-8"))}
    assert int(rows["7001"]["carried"]) == len(course[2]["7001"])


