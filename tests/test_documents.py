"""gradekit generate: sheets without answers, keys with them, safe folders, idempotent runs."""

from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path

import pytest

pypdf = pytest.importorskip("pypdf")

from gradekit.assignment import keys_for, load_assignment, student_variant  # noqa: E402
from gradekit.documents import generate  # noqa: E402
from gradekit.documents.typeset import Typ, num, paragraphs, string, text  # noqa: E402
from gradekit.errors import GradekitError  # noqa: E402
from gradekit.grading.exports import safe_names  # noqa: E402
from gradekit.numbers import fmt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

ASSIGNMENT = """\
title: "Test homework"
course: MEG373
term: "Fall 2026"
due: "2026-12-04"
salt: "test-docs"
instructions: "Use your own values."
submission: "Upload answers.csv."
problems:
  - {id: ch5-ex5-1, points: 10}
  - {id: ch5-ex5-3, points: 20}
"""

ROSTER = """\
student_id,name,email
1001,Zoë Łukasiewicz,zoe@example.edu
../evil,Eve #1 $x$ *b* _i_ @r <l> \\n,eve@example.edu
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    base = tmp_path_factory.mktemp("gen")
    asg = base / "hw.yaml"
    asg.write_text(ASSIGNMENT, encoding="utf-8")
    roster = base / "roster.csv"
    roster.write_text(ROSTER, encoding="utf-8")
    out = base / "out"
    summary = generate(asg, roster, out, progress=False)
    return asg, roster, out, summary


def _pdf_text(path: Path) -> str:
    reader = pypdf.PdfReader(str(path))
    meta = " ".join(str(v) for v in (reader.metadata or {}).values())
    return meta + "\n" + "\n".join(page.extract_text() or "" for page in reader.pages)


def _norm(s: str) -> str:
    return s.replace("−", "-").replace("\u00a0", " ")


def _answers(asg_path: Path, sid: str):
    asg = load_assignment(asg_path)
    out = []
    for item in asg.items:
        v = student_variant(asg, item, sid)
        given = {fmt(x, k) for x in v.result.values.values() for k in (3, 4, 5, 6)}
        out.append((v, keys_for(asg, item, sid, v, with_mistakes=False), given))
    return out


def test_layout_and_safe_folders(run):
    _, _, out, summary = run
    names = safe_names(["1001", "../evil"])
    assert names["../evil"] != "../evil"
    for safe in names.values():
        assert (out / "students" / safe / "assignment.pdf").is_file()
        assert (out / "students" / safe / "answers.csv").is_file()
        assert (out / "keys" / f"{safe}.pdf").is_file()
    for name in ("key.csv", "assignments.pdf", "keys.pdf", "manifest.json"):
        assert (out / name).is_file()
    written = {p.resolve() for p in out.parent.rglob("*") if p.is_file()}
    assert all(out.resolve() in p.parents or p.parent == out.parent.resolve() for p in written)
    assert not (out.parent / "evil").exists() and not (out / ".build").exists()
    assert summary.students == 2


def test_sheet_has_own_values_and_name_never_an_answer(run):
    asg, _, out, _ = run
    names = safe_names(["1001", "../evil"])
    for sid, name in (("1001", "Zoë Łukasiewicz"), ("../evil", "Eve #1 $x$ *b* _i_ @r <l> \\n")):
        body = _norm(_pdf_text(out / "students" / names[sid] / "assignment.pdf"))
        assert name in body
        assert sid in body
        header = load_assignment(asg)
        for fixed in (header.due, header.term, "100 %"):  # numbers every sheet prints, not the student's
            body = body.replace(_norm(fixed), " ")
        # numbers standing alone (not the 12 of a label F12)
        tokens = set(re.findall(r"(?<![A-Za-z\d.])-?\d+(?:\.\d+)?", body))
        answers = _answers(asg, sid)
        given_anywhere = set().union(*(g for _, _, g in answers))  # a value printed for another problem
        for v, entries, _given in answers:
            for par, value in v.values.items():
                if par in v.problem.parameters and v.problem.parameters[par].random:
                    assert fmt(value, 6) in tokens, (sid, par, value)
            for e in entries:
                for sig in (3, 4, 5):
                    shown = fmt(e.value, sig)
                    if shown in given_anywhere or len(shown.lstrip("-").replace(".", "")) < 3:
                        continue  # an answer equal to a given value, or too coarse (12 is also in BC²/12)
                    assert shown not in tokens and shown.lstrip("-") not in tokens, (sid, e.key, shown)


def test_only_the_key_names_the_course_documents_example(run):
    asg, _, out, _ = run
    refs = [load_assignment(asg).items[i].problem.source["ref"] for i in range(2)]
    assert all(refs)  # "Example 5.1, §5.3.1": the published solution, with the book's numbers
    sheet = _norm(_pdf_text(out / "students" / "1001" / "assignment.pdf"))
    key = _norm(_pdf_text(out / "keys" / "1001.pdf"))
    for ref in refs:
        number = ref.split(",")[0]
        assert number not in sheet
        assert number in key


def test_keys_hold_the_answers(run):
    asg, _, out, _ = run
    names = safe_names(["1001", "../evil"])
    all_keys = _norm(_pdf_text(out / "keys.pdf"))
    with open(out / "key.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[:6] == ["student_id", "key", "value", "unit", "tolerance", "points"]
    for sid in ("1001", "../evil"):
        key = _norm(_pdf_text(out / "keys" / f"{names[sid]}.pdf"))
        mine = {r["key"]: r for r in rows if r["student_id"] == sid}
        for _, entries, _ in _answers(asg, sid):
            for e in entries:
                assert fmt(e.value, 5) in key and fmt(e.value, 5) in all_keys
                assert float(mine[e.key]["value"]) == pytest.approx(e.value, rel=1e-7)
                assert mine[e.key]["unit"] == e.unit


def test_answers_template(run):
    asg, _, out, _ = run
    names = safe_names(["1001", "../evil"])
    with open(out / "students" / names["1001"] / "answers.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["student_id", "key", "value", "unit"]
    expected = [e.key for _, entries, _ in _answers(asg, "1001") for e in entries]
    assert [r[1] for r in rows[1:]] == expected
    assert all(r[0] == "1001" and r[2] == "" and r[3] for r in rows[1:])


def test_rerun_is_identical_and_one_student(run):
    asg, roster, out, _ = run
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    summary = generate(asg, roster, out, progress=False, student="1001")
    assert summary.students == 1
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before


def test_bad_roster_is_one_line(tmp_path):
    asg = tmp_path / "hw.yaml"
    asg.write_text(ASSIGNMENT, encoding="utf-8")
    roster = tmp_path / "roster.csv"
    roster.write_text("student_id,name\n1001,A\n1001,B\n", encoding="utf-8")
    with pytest.raises(GradekitError) as exc:
        generate(asg, roster, tmp_path / "out", progress=False)
    msg = exc.value.format_message()
    assert "\n" not in msg and str(roster) in msg and "1001" in msg
    roster.write_text("student_id,name\n1001,A\n", encoding="utf-8")
    with pytest.raises(GradekitError) as exc:
        generate(asg, roster, tmp_path / "out", progress=False, student="9999")
    assert "9999" in exc.value.format_message()


def test_unknown_problem_is_one_line(tmp_path):
    asg = tmp_path / "hw.yaml"
    asg.write_text(ASSIGNMENT.replace("ch5-ex5-3", "no-such-problem"), encoding="utf-8")
    roster = tmp_path / "roster.csv"
    roster.write_text("student_id,name\n1001,A\n", encoding="utf-8")
    with pytest.raises(GradekitError) as exc:
        generate(asg, roster, tmp_path / "out", progress=False)
    msg = exc.value.format_message()
    assert "\n" not in msg and "no-such-problem" in msg and str(asg) in msg


def test_escaping():
    assert string('a"b\\c\nd') == '"a\\"b\\\\c\\nd"'
    assert text("#x $y$") == '#"#x $y$"'
    assert isinstance(num(-1.5), Typ) and num(-1.5) == "−1.5"
    assert paragraphs("a\nb\n\nc") == '#"a b"\n\n#"c"'


def _files(folder: Path, keys: bool) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and p.name not in ("manifest.json", ".gradekit-generate")  # (the secret: listed once made)
            and (keys == ("keys" in p.parts or p.name == "keys.pdf"))}


def test_parallel_run_writes_the_same_files(run, tmp_path):
    """Two jobs write the same files as one (the course's secret carried over, so the same access codes)."""
    asg, roster, out, _ = run
    other = tmp_path / "out"
    other.mkdir()
    shutil.copy(out / "serve.secret", other / "serve.secret")
    generate(asg, roster, other, jobs=2, progress=False)
    assert _files(other, keys=False) == _files(out, keys=False)
    assert set(_files(other, keys=True)) == set(_files(out, keys=True))


def test_parallel_keys_are_identical(run, tmp_path):
    asg, roster, out, _ = run
    other = tmp_path / "out"
    generate(asg, roster, other, jobs=2, progress=False)
    assert _files(other, keys=True) == _files(out, keys=True)


def test_key_shows_the_route_only_where_needed(run):
    """p1 (ch5-ex5-1) is static and graphical, p2 (ch5-ex5-3) dynamic and analytical: each key shows
    the loop closure and every link's equilibrium, and only its own kind of route."""
    _, _, out, _ = run
    names = safe_names(["1001", "../evil"])
    body = _norm(_pdf_text(out / "keys" / f"{names['1001']}.pdf"))
    p1, p2 = body.split("p2. ", 1)
    for part in (p1, p2):
        assert "Loop closure" in part and "Equilibrium of each link" in part and "Link 1 (moments about" in part
    assert "Graphical construction" in p1 and "two-force member" in p1
    assert "Inertia forces and couples" not in p1 and "Velocity" not in p1 and "assembled system" not in p1
    assert "Inertia forces and couples" in p2 and "Velocity" in p2 and "Acceleration" in p2
    assert "The assembled system" in p2 and "Graphical construction" not in p2
