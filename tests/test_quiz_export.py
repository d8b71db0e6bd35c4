"""`gradekit export-quiz`: Moodle XML and Canvas QTI 1.2 read as their importers read them, every tolerance
the grader's band for its variant, an answer at the band's edge inside and just beyond it outside."""

from __future__ import annotations

import base64
import re
import xml.etree.ElementTree as ET
import zipfile

import pytest
from click.testing import CliRunner

from gradekit.assignment import keys_for, load_assignment, student_variant
from gradekit.cli import main
from gradekit.grading import Answer, compare
from gradekit.quiz import quiz_student

N = 3
ASSIGNMENT = """\
title: "HW 9: a/b <quiz>"
course: MEG373
salt: quiz-test
problems:
  - {id: ch5-ex5-1, points: 10}
  - {id: ch5-ex5-3, points: 20}
"""
# Moodle's grade choices (question_bank::fraction_options), in percent
MOODLE_FRACTIONS = {100, 90, 83.33333, 80, 75, 70, 66.66667, 60, 50, 40, 33.33333, 30, 25, 20, 16.66667, 14.28571,
                    12.5, 11.11111, 10, 5, 0}
# qtype_multianswer's NUMBER_REGEX and the NUMERICAL alternative "%fraction%value:tolerance"
NUMBER = r"-?(?:(?:[0-9]+[.,]?[0-9]*|[.,][0-9]+)(?:[eE][-+]?[0-9]+)?)"
FRACTION = r"(?:=|%(-?[0-9]+(?:[.,][0-9]*)?)%)"
CLOZE = re.compile(r"\{([0-9]*):(?:NUMERICAL|NM):" + FRACTION + "(" + NUMBER + "):(" + NUMBER + r")\}")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    root = tmp_path_factory.mktemp("quiz")
    (root / "hw9.yaml").write_text(ASSIGNMENT, encoding="utf-8")
    runner = CliRunner()
    for fmt, name in (("moodle-xml", "quiz.xml"), ("canvas-qti", "quiz.zip")):
        r = runner.invoke(main, ["export-quiz", str(root / "hw9.yaml"), "--format", fmt, "--variants", str(N),
                                 "--out", str(root / name)])
        assert r.exit_code == 0, r.output
    asg = load_assignment(root / "hw9.yaml")
    keys = {}  # the grader's key entries of variant k of each problem, made as a student's key is
    for item in asg.items:
        for k in range(1, N + 1):
            v = student_variant(asg, item, quiz_student(k))
            keys[item.label, k] = {e.key: e for e in keys_for(asg, item, quiz_student(k), v, with_mistakes=False)
                                   if not e.hand_check}  # (no band grades those: not in the pool)
    return root, keys


def graded(entry, value: float) -> bool:
    """The grader's own verdict on *value* typed in the key's unit."""
    return compare(entry, Answer(entry.key, repr(value), "", value, "", 2)).correct


def check_edges(entry, lower: float, upper: float) -> None:
    """The quiz's accepted range is the grader's: both ends inside, a hair beyond each outside."""
    band = entry.tolerance.band(entry.value)
    assert band > 0
    assert lower == entry.value - band and upper == entry.value + band
    assert graded(entry, lower) and graded(entry, upper)
    assert not graded(entry, upper + 1e-9 * band + 1e-12 * abs(entry.value))
    assert not graded(entry, lower - 1e-9 * band - 1e-12 * abs(entry.value))


def test_moodle_xml_is_a_category_per_problem_and_a_cloze_question_per_variant(exported) -> None:
    exported, key_entries = exported
    raw = (exported / "quiz.xml").read_text(encoding="utf-8")
    quiz = ET.fromstring(raw)
    assert quiz.tag == "quiz"
    questions = list(quiz)
    kinds = [q.get("type") for q in questions]
    assert kinds == ["category", *["cloze"] * N, "category", *["cloze"] * N]
    assert questions[0].findtext("category/text") == (
        "$course$/top/HW 9: a//b <quiz>/p1: Static force analysis of a compressor slider crank")
    assert raw.count("<![CDATA[") == 2 * N  # every question's HTML in CDATA
    checked = 0
    for q in questions:
        if q.get("type") != "cloze":
            continue
        name = q.findtext("name/text")
        label, k = re.fullmatch(r"(p\d) variant (\d+): .+", name).groups()
        text = q.find("questiontext")
        assert text.get("format") == "html"
        html_text = text.findtext("text")
        files = {f.get("name"): base64.b64decode(f.text) for f in text.findall("file")}
        sources = re.findall(r'<img src="@@PLUGINFILE@@/([^"]+)" alt="([^"]+)">', html_text)
        assert sources and {s for s, _ in sources} == set(files)  # each image referenced and present
        assert all(png.startswith(b"\x89PNG\r\n\x1a\n") for png in files.values())
        assert all(len(alt) > 20 for _, alt in sources)
        keys = key_entries[label, int(k)]
        boxes = CLOZE.findall(html_text)
        assert len(boxes) == len(keys)
        for (weight, fraction, value, tolerance), entry in zip(boxes, keys.values(), strict=True):
            assert float(fraction) in MOODLE_FRACTIONS and int(weight) >= 1
            assert float(value) == entry.value
            assert float(tolerance) == entry.tolerance.band(entry.value)  # absolute, the grader's band
            check_edges(entry, float(value) - float(tolerance), float(value) + float(tolerance))
            if entry.sign_convention:
                assert entry.sign_convention in html_text
            checked += 1
    assert checked >= 2 * N


def test_canvas_qti_package_has_a_question_group_per_answer_and_explicit_bounds(exported) -> None:
    exported, key_entries = exported
    ns = {"q": "http://www.imsglobal.org/xsd/ims_qtiasiv1p2"}
    with zipfile.ZipFile(exported / "quiz.zip") as z:
        names = set(z.namelist())
        manifest = ET.fromstring(z.read("imsmanifest.xml"))
        listed = {f.get("href") for f in manifest.iter("{http://www.imsglobal.org/xsd/imscp_v1p1}file")}
        assert listed == names - {"imsmanifest.xml"}
        resources = list(manifest.iter("{http://www.imsglobal.org/xsd/imscp_v1p1}resource"))
        assert [r.get("type") for r in resources] == ["imsqti_xmlv1p2"] * 2
        checked = 0
        for resource in resources:
            xml_file = next(f.get("href") for f in resource if f.get("href").endswith(".xml"))
            doc = ET.fromstring(z.read(xml_file))
            assessment = doc.find("q:assessment", ns)
            groups = assessment.findall("q:section/q:section", ns)
            assert groups
            for group in groups:
                assert group.findtext("q:selection_ordering/q:selection/q:selection_number", namespaces=ns) == "1"
                items = group.findall("q:item", ns)
                assert len(items) == N
                for item in items:
                    fields = {f.findtext("q:fieldlabel", namespaces=ns): f.findtext("q:fieldentry", namespaces=ns)
                              for f in item.iter(f"{{{ns['q']}}}qtimetadatafield")}
                    assert fields["question_type"] == "numerical_question"
                    label, k, key = re.fullmatch(r"(p\d) variant (\d+): (\S+)", item.get("title")).groups()
                    entry = key_entries[label, int(k)][key]
                    assert float(fields["points_possible"]) == entry.points
                    text = item.findtext("q:presentation/q:material/q:mattext", namespaces=ns)
                    for src in re.findall(r'<img src="\.\./([^"]+)"', text):
                        assert src in names  # the image is in the package
                    assert pretty_unit(entry.unit) in text
                    lower = float(item.findtext(".//q:conditionvar/q:vargte", namespaces=ns))
                    upper = float(item.findtext(".//q:conditionvar/q:varlte", namespaces=ns))
                    check_edges(entry, lower, upper)
                    checked += 1
        assert checked > 2 * N


def pretty_unit(unit: str) -> str:
    from gradekit.units import pretty

    return pretty(unit)


def test_bad_format_and_variant_count_are_usage_errors(exported) -> None:
    exported, _ = exported
    runner = CliRunner()
    r = runner.invoke(main, ["export-quiz", str(exported / "hw9.yaml"), "--format", "blackboard", "--out", "x"])
    assert r.exit_code == 2 and "'blackboard' is not one of 'moodle-xml', 'canvas-qti'" in r.output
    r = runner.invoke(main, ["export-quiz", str(exported / "hw9.yaml"), "--format", "moodle-xml", "--variants", "0",
                             "--out", "x"])
    assert r.exit_code == 2 and "--variants" in r.output
