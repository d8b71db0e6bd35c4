"""Feedback file names that stay inside OUT and never collide; generic mistakes; integrity."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gradekit.grading.compare import compare, diagnose, generic_mistakes
from gradekit.grading.feedback import feedback_html, feedback_markdown
from gradekit.grading.reader import Answer
from gradekit.roster import safe_name, safe_names
from gradekit.solving.keys import KeyEntry, Mistake, Tolerance


@pytest.mark.parametrize(
    "student_id",
    [
        "../x",
        "a/b",
        "a\\b",
        "CON",
        "con.txt",
        "Lpt1",
        "..",
        ".",
        "",
        " ",
        "x" * 300,
        "../../etc/passwd",
        "a\x00b",
        "é",
    ],
)
def test_safe_names_stay_inside_out(tmp_path: Path, student_id: str) -> None:
    name = safe_name(student_id)
    path = (tmp_path / f"{name}.md").resolve()
    assert path.parent == tmp_path.resolve()
    assert name not in ("", ".", "..") and "/" not in name and "\\" not in name
    assert name.split(".")[0].upper() not in {"CON", "PRN", "AUX", "NUL", "LPT1"}
    assert len(name) <= 64


def test_safe_names_keep_plain_ids_and_mark_changed_ones() -> None:
    assert safe_name("12345") == "12345"
    assert safe_name("s-12_a") == "s-12_a"
    assert safe_name("../x") == "x-" + __import__("hashlib").sha256(b"../x").hexdigest()[:8]


def test_ids_never_share_a_file_name() -> None:
    ids = ["a/b", "a_b", "a\\b", "a b", "AB", "ab", "Ab", "CON", "con", "con-1", "x", "X", "../x", "./x"]
    names = safe_names(ids)
    assert len({n.casefold() for n in names.values()}) == len(ids)
    assert names["a_b"] == "a_b" and names["ab"] == "ab" and names["x"] == "x"


ENTRY = KeyEntry(
    "1",
    "p1",
    "p1.T",
    1.12,
    "N*m",
    Tolerance("relative", rel=0.01),
    points=2.0,
    sign_convention="counter-clockwise positive",
    mistakes=(Mistake("inertia torque left out", "the inertia torque of link 3 is missing", 0.87),),
)


def test_generic_mistakes() -> None:
    found = generic_mistakes(ENTRY)
    assert [m.name for m in found] == ["sign flipped", "×1000 unit slip", "÷1000 unit slip"]
    assert [m.value for m in found] == pytest.approx([-1.12, 1120.0, 0.00112])
    assert found[0].description == "the sign is reversed (convention: counter-clockwise positive)"
    angle = KeyEntry("1", "p1", "p1.th", 0.5, "rad", Tolerance())
    assert [m.name for m in generic_mistakes(angle)][-1] == "degrees for radians"
    assert generic_mistakes(angle)[-1].value == pytest.approx(0.5 * 180 / math.pi)
    degrees = KeyEntry("1", "p1", "p1.th", 30.0, "deg", Tolerance())
    assert generic_mistakes(degrees)[-1].value == pytest.approx(math.pi / 6)
    zero = KeyEntry("1", "p1", "p1.F", 0.0, "N", Tolerance(abs=0.1))
    assert "sign flipped" not in [m.name for m in generic_mistakes(zero)]


@pytest.mark.parametrize(
    ("unit", "names"),
    [
        ("deg", ["sign flipped", "radians for degrees"]),
        ("rad/s", ["sign flipped", "degrees for radians"]),
        ("rad/s**2", ["sign flipped", "degrees for radians"]),
        ("N*m", ["sign flipped", "×1000 unit slip", "÷1000 unit slip"]),
        ("mm/s**2", ["sign flipped", "×1000 unit slip", "÷1000 unit slip"]),
    ],
)
def test_a_unit_slip_is_offered_only_where_a_prefix_can_slip(unit: str, names: list[str]) -> None:
    """An angle or an angle per time takes no SI prefix, so it has no ×1000 or ÷1000 slip."""
    assert [m.name for m in generic_mistakes(KeyEntry("1", "p1", "p1.x", 10.0, unit, Tolerance()))] == names


def test_a_wrong_direction_round_the_circle_from_1000_times_its_key_is_no_unit_slip() -> None:
    """Key 10° (band ±2°): 1000 × 10° = 10,000° = 27 × 360° + 280°, so 280° lies on the ×1000 value
    around the circle; the sign flip (350°) is 70° away and radians for degrees (0.17°) 80°, so nothing
    catalogued explains it. Likewise 2,000 rad/s against a key of 2 rad/s."""
    direction = KeyEntry("1", "p1", "p1.dir", 10.0, "deg", Tolerance(rel=0.0, abs=2.0, period=360.0))
    assert diagnose(direction, 280.0) is None
    assert diagnose(direction, 350.0).name == "sign flipped"
    rate = KeyEntry("1", "p1", "p1.w", 2.0, "rad/s", Tolerance(rel=0.01))
    assert diagnose(rate, 2000.0) is None
    assert compare(rate, Answer("p1.w", "2000", "", 2000.0, "", 2)).diagnosis is None


@pytest.mark.parametrize(
    ("raw", "unit", "correct", "diagnosis"),
    [
        ("1.12", "", True, None),
        ("1.125", "N*m", True, None),
        ("-1.12", "", False, "sign flipped"),
        ("1120", "", False, "×1000 unit slip"),
        ("1120", "N*mm", True, None),
        ("0.871", "", False, "inertia torque left out"),
        ("9.91", "lbf*in", True, None),  # 9.91 lbf·in = 1.1197 N·m
        ("1.2", "", False, None),
    ],
)
def test_compare_and_diagnose(raw: str, unit: str, correct: bool, diagnosis: str | None) -> None:
    answer = Answer("p1.T", raw, unit, float(raw), unit, 2)
    result = compare(ENTRY, answer)
    assert result.correct is correct
    assert (result.diagnosis.name if result.diagnosis else None) == diagnosis
    assert result.points == (2.0 if correct else 0.0)


@pytest.mark.parametrize(
    ("key", "key_unit", "raw", "raw_unit", "unit", "points"),
    [
        ("p1.T_<a>|b", "N*m", "1120", "N*mm", "N*mm", 2.0),  # escaped key, converted value
        ("p2.x", "kN", "1.5", "", "", 1.5),  # no unit given
        ("p2.x", "kN", "1.5e0", "[kN]", "kN", 0.25),  # a value the formatter rewrites; a bracketed unit
        ("p3.&'\"", "deg", "30", "°", "deg", 1),  # HTML escapes in the key; a written degree sign
    ],
)
def test_a_feedback_row_is_one_set_of_cells_escaped_for_markdown_and_html(
    key: str, key_unit: str, raw: str, raw_unit: str, unit: str, points: float
) -> None:
    """Markdown and HTML show the same cells: unescaping each row gives the row's plain cells."""
    import html
    import re

    from gradekit.grading.feedback import feedback_row, html_row, markdown_row
    from gradekit.numbers import fmt

    value = float(raw) * {"N*mm": 1e-3}.get(unit, 1.0)
    entry = KeyEntry("1", "p1", key, value, key_unit, Tolerance(rel=0.01), points)
    row = feedback_row(compare(entry, Answer(key, raw, raw_unit, float(raw), unit, 2)), reveal=False)
    assert row.verdict == "right" and row.cells[0] == key and row.cells[3] == "right"
    assert row.cells[2].startswith(fmt(float(raw), 6))  # the value as read, through the one formatter
    assert row.cells[1] == raw + (f" [{raw_unit}]" if raw_unit else "")
    md = markdown_row(row)
    md_cells = [re.sub(r"\\(.)", r"\1", c) for c in re.split(r"(?<!\\) \| ", md[2:-2])]
    assert md_cells == list(row.cells)
    page = html_row(row)
    assert page.startswith('<tr class="right"><td>') and page.endswith("</td></tr>")
    assert [html.unescape(c) for c in page[len('<tr class="right"><td>'):-len("</td></tr>")].split("</td><td>")] == \
        list(row.cells)


def test_feedback_names_the_file_as_submitted_never_the_instructors_path(tmp_path: Path) -> None:
    from gradekit.grading.compare import grade_student
    from gradekit.grading.reader import Issue, Submission
    from gradekit.roster import Student

    path = str(tmp_path / "Selam Haile_4242_assignsubmission_file_" / "answers.csv")
    sub = Submission(path, "1", (Answer("p1.T", "1.12", "", 1.12, "", 2),),
                     issues=(Issue(path, 3, "value", "expected a number, got x"),))
    grade = grade_student(Student("1", "Selam Haile"), [ENTRY], sub)
    for text in (feedback_markdown(grade, {}, "HW", reveal=False), feedback_html(grade, {}, "HW", reveal=False)):
        assert str(tmp_path) not in text
        assert "answers.csv:3: value: expected a number, got x" in text
    assert "Graded file: answers.csv" in feedback_markdown(grade, {}, "HW", reveal=False)
    canvas = Submission(str(tmp_path / "hailesela_late_77_88_answers-1.csv"), "1", ())
    page = feedback_html(grade_student(Student("1", "Selam Haile"), [ENTRY], canvas), {}, "HW", reveal=False)
    assert "Graded file: <code>answers-1.csv</code>" in page and str(tmp_path) not in page


def test_entry_mistakes_take_precedence_over_generic_ones() -> None:
    entry = KeyEntry(
        "1", "p1", "p1.T", 1.0, "N*m", Tolerance(), mistakes=(Mistake("sign flipped", "custom", -1.0),)
    )
    found = diagnose(entry, -1.0)
    assert found is not None and found.description == "custom"


def test_the_closest_mistake_is_named_and_an_own_one_wins_a_tie() -> None:
    own = (Mistake("sign flipped", "own flip", -3.0), Mistake("static answer", "own static", 2000.0))
    entry = KeyEntry("1", "p1", "p1.T", 2.0, "N*m", Tolerance(), sign_convention="CCW positive", mistakes=own)
    assert diagnose(entry, -2.0) is None  # its own "sign flipped" stands for the generic one
    assert diagnose(entry, 2000.0).description == "own static"  # the same value as the ×1000 slip
    assert diagnose(entry, 0.002).name == "÷1000 unit slip"
    plain = KeyEntry("1", "p1", "p1.T", 1.0, "N*m", Tolerance(rel=0.2), sign_convention="CCW positive",
                     mistakes=(Mistake("static answer", "own static", 1100.0),))
    assert diagnose(plain, 1000.0).name == "×1000 unit slip"  # both bands hold it; the slip is closer
    assert diagnose(plain, -1.0).description == "the sign is reversed (convention: CCW positive)"
    angle = KeyEntry("1", "p1", "p1.th", 10.0, "deg", Tolerance(rel=0.0, abs=0.5, period=360.0))
    assert diagnose(angle, 350.0).name == "sign flipped"  # −10° wrapped
    assert diagnose(angle, 10 * math.pi / 180).name == "radians for degrees"


def test_a_direction_s_closest_mistake_is_measured_around_the_circle() -> None:
    """350° against a key of 10° (band ±0.1°): the sign flip (−10°) is 0° away around the circle, a catalogued
    mistake of 10,000° (band ±100°) 70°, 0.7 of its band. On the number line the flip is 3,600 bands away and
    the other mistake 96.5, which named that one."""
    far = Mistake("static answer", "own static", 10_000.0)
    direction = KeyEntry("1", "p1", "p1.dir", 10.0, "deg", Tolerance(rel=0.01, period=360.0), mistakes=(far,))
    assert diagnose(direction, 350.0).name == "sign flipped"
    assert diagnose(direction, 350.0 + 720.0).name == "sign flipped"


def test_feedback_escapes_what_students_wrote() -> None:
    from gradekit.grading.compare import grade_student
    from gradekit.grading.reader import Submission
    from gradekit.roster import Student

    student = Student("1", "<script>alert(1)</script> | x")
    sub = Submission(
        "s.csv", "1", (Answer("p1.T", "<b>1.12</b>|", "", None, "", 2, issue="expected a number"),)
    )
    grade = grade_student(student, [ENTRY], sub)
    page = feedback_html(grade, {}, "HW", reveal=False)
    assert "<script>" not in page and "&lt;script&gt;" in page and "&lt;b&gt;1.12&lt;/b&gt;|" in page
    text = feedback_markdown(grade, {}, "HW", reveal=False)
    assert "\\<b\\>1.12\\</b\\>\\|" in text and "\\<script\\>" in text


def test_angle_error_is_wrapped_degrees_never_relative() -> None:
    entry = KeyEntry("1", "p1", "p1.dir", 0.3, "deg", Tolerance("relative", rel=0.0, abs=0.5, period=360.0))
    near = compare(entry, Answer("p1.dir", "359.9", "", 359.9, "", 2))
    assert near.correct and near.rel_error is None and near.abs_error == pytest.approx(0.4)
    far = compare(entry, Answer("p1.dir", "2.3", "", 2.3, "", 2))
    assert not far.correct and far.rel_error is None and far.error == pytest.approx(2.0)
    plain = KeyEntry("1", "p1", "p1.th", 337.4, "deg", Tolerance("relative", rel=0.001))  # no period given
    r = compare(plain, Answer("p1.th", "-20.6", "", -20.6, "", 3))
    assert r.rel_error is None and r.abs_error == pytest.approx(2.0)
