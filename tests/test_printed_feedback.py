"""Feedback, reports and LMS exports as written to disk: exactly true, never a key handed out.

Every check reads the files `grade_batch` writes (feedback Markdown/HTML, report.md, canvas.csv,
moodle.csv, histogram.svg) or what the CLI prints.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from gradekit.cli import main
from gradekit.grading import grade_batch
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Mistake, Tolerance

ROOT = Path(__file__).resolve().parents[1]
ANGLE = Tolerance("relative", rel=0.0, abs=0.5, period=360.0)
REL = Tolerance("relative", rel=0.02)


def _keys(sid: str, angle: float, force: float) -> list[KeyEntry]:
    return [
        KeyEntry(sid, "p1", "p1.dir", angle, "deg", ANGLE, 1.0, "direction of F", "degrees CCW from +x"),
        KeyEntry(sid, "p1", "p1.F", force, "N", REL, 1.5, "force, magnitude"),
        KeyEntry(sid, "p1", "p1.T", 2.0, "N*m", REL, 1.5, "torque", "counterclockwise positive"),
    ]


def _write(folder: Path, sid: str, rows: list[tuple[str, str, str]]) -> None:
    lines = ["student_id,key,value,unit"] + [f"{sid},{k},{v},{u}" for k, v, u in rows]
    (folder / f"{sid}.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    base = tmp_path_factory.mktemp("fb")
    subs = base / "subs"
    subs.mkdir()
    students = [
        Student("a1", "Ann Angle", "a1@x.edu"),
        Student("b2", "Bea\nNewline\tTab\x07", "b2@x.edu", section="A\r\nB"),
        Student("c3", "Cal Blank", "c3@x.edu"),
        Student("d4", "Dee Perfect", "d4@x.edu"),
    ]
    keys = (_keys("a1", 337.4, 100.0) + _keys("b2", 0.3, 100.0) + _keys("c3", 10.0, 100.0)
            + _keys("d4", 45.0, 100.0))
    # a1: 2° off (337.4 → 339.4) and force 30 % too high; b2: 0.5° off across 0°/360° -> 359.8
    _write(subs, "a1", [("p1.dir", "339.4", "deg"), ("p1.F", "130", "N"), ("p1.T", "2", "N*m")])
    _write(subs, "b2", [("p1.dir", "359.8", "deg"), ("p1.F", "70", "N"), ("p1.T", "2", "N·m")])
    _write(subs, "c3", [("p1.dir", "", "deg"), ("p1.F", "", "N"), ("p1.T", "", "N*m")])  # the template, unfilled
    # every answer right; points 1 + 1.5 + 1.5 can sum to 100.00000000000001 %
    _write(subs, "d4", [("p1.dir", "45", "deg"), ("p1.F", "100", "N"), ("p1.T", "2000", "N*mm")])
    out = base / "out"
    result = grade_batch(keys, students, subs, out, assignment_title="HW\n9", problem_titles={"p1": "Four-bar"})
    out_reveal = base / "out_reveal"
    grade_batch(keys, students, subs, out_reveal, assignment_title="HW 9", reveal=True)
    return result, out, out_reveal


def test_angle_difference_is_degrees_wrapped_never_a_percentage(graded):
    _, _, out = graded
    a1 = (out / "feedback" / "a1.md").read_text(encoding="utf-8")
    row = next(line for line in a1.splitlines() if line.startswith("| p1.dir"))
    assert "2° counterclockwise (wrapped at 360°)" in row and "%" not in row
    b2 = (out / "feedback" / "b2.md").read_text(encoding="utf-8")
    row = next(line for line in b2.splitlines() if line.startswith("| p1.dir"))
    # 0.3° asked, 359.8° given: 0.5° clockwise after wrapping (accepted at ±0.5°), not "Off by 106 %"
    assert "| right |" in row and "%" not in row
    row_f = next(line for line in a1.splitlines() if line.startswith("| p1.F"))
    assert "+30 %" in row_f


def test_without_reveal_no_signed_amount_lets_a_student_back_out_the_key(graded):
    _, out, _ = graded
    for sid in ("a1", "b2"):
        for ext in ("md", "html"):
            text = (out / "feedback" / f"{sid}.{ext}").read_text(encoding="utf-8")
            assert not re.search(r"\d+(\.\d+)? ?%\s*\|", text.replace("(", "|"))  # no "30 %" cell
            shown = text.replace("339.4 ", "").replace(">339.4<", "").replace("339.4°", "")  # the student's own
            assert "30 %" not in text and "339.4" not in shown
            assert "outside the tolerance" in text
    a1 = (out / "feedback" / "a1.md").read_text(encoding="utf-8")
    assert "too high, outside the tolerance" in next(x for x in a1.splitlines() if x.startswith("| p1.F"))
    assert "too far counterclockwise, outside the tolerance" in next(
        x for x in a1.splitlines() if x.startswith("| p1.dir"))
    b2 = (out / "feedback" / "b2.md").read_text(encoding="utf-8")
    assert "too low, outside the tolerance" in next(x for x in b2.splitlines() if x.startswith("| p1.F"))


def test_an_unfilled_file_gives_one_message(graded):
    _, out, _ = graded
    c3 = (out / "feedback" / "c3.md").read_text(encoding="utf-8")
    issues = c3.split("## Problems reading your file", 1)[1].strip().splitlines()
    assert len(issues) == 1, issues
    assert "blank cell" in issues[0] and "in 3 rows" in issues[0]
    report = (out / "report.md").read_text(encoding="utf-8")
    messages = report.split("## Messages", 1)[1]
    assert messages.count("- c3:") == 1


def test_lms_exports_keep_every_name_on_one_line(graded):
    _, out, _ = graded
    for name in ("canvas.csv", "moodle.csv", "grades.csv"):
        raw = (out / name).read_text(encoding="utf-8")
        rows = list(csv.reader(raw.splitlines()))
        assert len(rows) == 5, f"{name}: a name broke a row: {raw!r}"
        for row in rows:
            for cell in row:
                assert not re.search(r"[\x00-\x1f\x7f]", cell), (name, cell)
    canvas = list(csv.DictReader((out / "canvas.csv").open(encoding="utf-8")))
    bea = next(r for r in canvas if r["SIS User ID"] == "b2")
    assert bea["Student"] == "Bea Newline Tab" and bea["Section"] == "A B"


def test_histogram_counts_perfect_scores(graded, tmp_path):
    result, out, _ = graded
    d4 = next(g for g in result.grades if g.student.student_id == "d4")
    assert d4.total == d4.max_points
    from gradekit.grading.exports import write_histogram

    svg = tmp_path / "h.svg"
    counts = _histogram_counts(write_histogram, svg, [100.00000000000001, 100.0, 55.0])
    assert counts[-1] == 2 and sum(counts) == 3


def test_histogram_title_is_text(tmp_path):
    """The instructor's title reaches the SVG as text: markup in it is escaped, the file still parses."""
    import xml.etree.ElementTree as ET

    from gradekit.grading.exports import write_histogram

    title = '<script>alert(1)</script> & "HW" $5'
    write_histogram(tmp_path / "h.svg", [10.0, 95.0], title)
    root = ET.parse(tmp_path / "h.svg").getroot()
    texts = [e.text for e in root.iter() if e.text]
    assert title in texts and not list(root.iter("{http://www.w3.org/2000/svg}script"))
    assert "0–10 %: 0, 10–20 %: 1" in root.find("{http://www.w3.org/2000/svg}desc").text


def _histogram_counts(write, path, percents):
    """The bar heights of the histogram `write_histogram` draws for *percents*, read from the SVG."""
    import xml.etree.ElementTree as ET

    write(path, percents, "t")
    bars = [e for e in ET.parse(path).iter("{http://www.w3.org/2000/svg}rect") if e.get("class") == "bar"]
    return [int(e.get("data-count")) for e in bars]


def test_solve_with_assignment_prints_the_sheets_values(tmp_path):
    from gradekit.documents import generate

    roster = tmp_path / "roster.csv"
    roster.write_text("student_id,name\n1001,A\n1002,B\n1003,C\n", encoding="utf-8")
    asg = ROOT / "examples" / "hw5.yaml"
    generate(asg, roster, tmp_path / "out", keys=False, student="1003", progress=False)
    keyed = {r["key"]: float(r["value"]) for r in csv.DictReader((tmp_path / "out" / "key.csv").open())
             if r["student_id"] == "1003" and r["problem"] == "p3"}
    runner = CliRunner()
    res = runner.invoke(main, ["solve", "s002-fourbar-120lb", "--student", "1003", "--assignment", str(asg),
                               "--manifest", str(tmp_path / "out" / "manifest.json"), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert keyed and {f"p3.{k}": v["value"] for k, v in data["answers"].items()} == pytest.approx(keyed, rel=1e-9)
    shown = runner.invoke(main, ["bank", "show", "p3", "--student", "1003", "--assignment", str(asg)])
    assert shown.exit_code == 0, shown.output
    assert "not any assignment" not in shown.output
    plain = runner.invoke(main, ["bank", "show", "s002-fourbar-120lb", "--student", "1003"])
    as_json = runner.invoke(main, ["solve", "s002-fourbar-120lb", "--student", "1003", "--json"])
    assert "not any assignment's sheet" in json.loads(as_json.stdout)["note"]
    assert plain.exit_code == 0 and "not any assignment's sheet" in plain.stderr
    bad = runner.invoke(main, ["solve", "p9", "--student", "1003", "--assignment", str(asg)])
    assert bad.exit_code == 1 and "expected a problem of the assignment" in bad.output


def test_band_hint_says_how_far_in_tolerances_never_the_amount():
    from gradekit.grading.compare import grade_student
    from gradekit.grading.feedback import feedback_markdown
    from gradekit.grading.reader import Answer, Submission

    answers = (Answer("p1.dir", "12", "deg", 12.0, "deg", 2), Answer("p1.F", "103", "N", 103.0, "N", 3),
               Answer("p1.T", "2.1", "N*m", 2.1, "N*m", 4))
    grade = grade_student(Student("e5", "E"), _keys("e5", 10.0, 100.0), Submission("e5.csv", "e5", answers))
    text = feedback_markdown(grade, {}, "HW", reveal=False, hint="band")
    off = {line.split("|")[1].strip(): line.split("|")[5].strip() for line in text.splitlines()
           if line.startswith("| p1.")}
    assert off == {
        "p1.dir": "too far counterclockwise, 2 to 10 times the tolerance away",  # 2° off, ±0.5°
        "p1.F": "too high, within twice the tolerance",  # 3 % off, ±2 %
        "p1.T": "too high, 2 to 10 times the tolerance away",  # 5 % off, ±2 %
    }


# Each slip below is a fixed transformation of the key: naming it would let a student compute the key
# from their own answer (−x, x/1000, the other component). A mistake of method (static answer to a
# dynamic problem, inertia torque or gravity left out) needs the left-out part computed: it may be named.
_SLIPS = {
    "p1.T": ("-2", "N*m", "sign flipped"),  # key 2 N·m
    "p1.M": ("3000", "N*m", "×1000 unit slip"),  # key 3 N·m
    "p1.Fx": ("40", "N", "x-y-swapped"),  # key 30 N, Fy = 40 N
    "p1.Fy": ("50", "N", "magnitude-for-component"),  # key 40 N, |F| = 50 N
}


def _method_keys(sid: str) -> list[KeyEntry]:
    inertia = Mistake("static-answer", "a static answer to a dynamic problem (inertia left out)", 80.0)
    gravity = Mistake("no-gravity", "gravity (the weights) left out", 7.0)
    swapped = Mistake("x-y-swapped", "the x and y components swapped", 40.0)
    as_mag = Mistake("magnitude-for-component", "the magnitude given for a component", 50.0)
    return [
        KeyEntry(sid, "p1", "p1.F", 100.0, "N", REL, 1, "force, magnitude", mistakes=(inertia,)),
        KeyEntry(sid, "p1", "p1.W", 10.0, "N", REL, 1, "weight share", mistakes=(gravity,)),
        KeyEntry(sid, "p1", "p1.T", 2.0, "N*m", REL, 1, "torque", "counterclockwise positive"),
        KeyEntry(sid, "p1", "p1.M", 3.0, "N*m", REL, 1, "moment"),
        KeyEntry(sid, "p1", "p1.Fx", 30.0, "N", REL, 1, "force, x", mistakes=(swapped, as_mag)),
        KeyEntry(sid, "p1", "p1.Fy", 40.0, "N", REL, 1, "force, y", mistakes=(as_mag,)),
    ]


@pytest.fixture(scope="module")
def slipped(tmp_path_factory):
    base = tmp_path_factory.mktemp("slips")
    subs = base / "subs"
    subs.mkdir()
    rows = [("p1.F", "80", "N"), ("p1.W", "7", "N"), *((k, v, u) for k, (v, u, _) in _SLIPS.items())]
    _write(subs, "s1", rows)
    students = [Student("s1", "Sam Slip", "s1@x.edu")]
    outs = {}
    for reveal in (False, True):
        outs[reveal] = base / f"out_{reveal}"
        grade_batch(_method_keys("s1"), students, subs, outs[reveal], assignment_title="HW", reveal=reveal)
    return outs


def _likely(text: str) -> dict[str, str]:
    return {line.split("|")[1].strip(): line.split("|")[6].strip() for line in text.splitlines()
            if line.startswith("| p1.")}


def test_without_reveal_only_mistakes_of_method_are_named(slipped):
    md = (slipped[False] / "feedback" / "s1.md").read_text(encoding="utf-8")
    html = (slipped[False] / "feedback" / "s1.html").read_text(encoding="utf-8")
    likely = _likely(md)
    assert likely["p1.F"].startswith("static-answer: a static answer to a dynamic problem")
    assert likely["p1.W"].startswith("no-gravity: gravity")
    for key in _SLIPS:  # every slip reads the same generic hint: it says nothing of the key
        assert likely[key] == "check the sign convention, the units and the component asked", key
    for text in (md, html):
        for _, _, name in _SLIPS.values():
            assert name not in text
        for word in ("sign is reversed", "1000 times", "components swapped", "magnitude given"):
            assert word not in text
        assert "names only a mistake of method" in text  # the feedback says why the rest is unnamed
    report = (slipped[False] / "report.md").read_text(encoding="utf-8")
    assert "sign flipped (1)" in report  # the instructor still sees every diagnosis


def test_with_reveal_every_diagnosis_is_named(slipped):
    md = (slipped[True] / "feedback" / "s1.md").read_text(encoding="utf-8")
    likely = _likely(md)
    assert likely["p1.F"].startswith("static-answer:")
    for key, (_, _, name) in _SLIPS.items():
        assert likely[key].startswith(name + ":"), (key, likely[key])
    assert "names only a mistake of method" not in md
