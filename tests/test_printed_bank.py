"""Every printed word is the student's own: one assignment holding every bank problem, read back
from the PDFs and CSVs that `gradekit generate` writes for several students.

Expected values come from each student's own variant (the same sampler the documents use), never
from numbers pinned today.
"""

from __future__ import annotations

import csv
import math
import re
from collections import defaultdict
from pathlib import Path

import pytest
import yaml

pypdf = pytest.importorskip("pypdf")

from gradekit import units  # noqa: E402
from gradekit.assignment import load_assignment, student_variant  # noqa: E402
from gradekit.bank.registry import load_bank  # noqa: E402
from gradekit.documents import generate  # noqa: E402
from gradekit.figures.sheet import ratio_text  # noqa: E402
from gradekit.numbers import fmt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
STUDENTS = ["s01", "s02", "s03"]
NUMBER = r"[−-]?\d+(?:\.\d+)?"


def _assignment(ids: list[str], salt: str) -> dict:
    return {
        "title": "Every bank problem",
        "course": "MEG373",
        "term": "Test",
        "salt": salt,
        "bank": str(ROOT / "problem_bank"),
        "problems": [{"id": pid, "points": 10} for pid in ids],
    }


@pytest.fixture(scope="module")
def bank_ids() -> list[str]:
    return sorted(load_bank(ROOT / "problem_bank"))


@pytest.fixture(scope="module")
def whole_bank(tmp_path_factory, bank_ids):
    base = tmp_path_factory.mktemp("bank")
    asg = base / "all.yaml"
    asg.write_text(yaml.safe_dump(_assignment(bank_ids, "printed-bank"), sort_keys=False), encoding="utf-8")
    roster = base / "roster.csv"
    roster.write_text("student_id,name,email\n" + "".join(f"{s},Student {s},{s}@x.edu\n" for s in STUDENTS),
                      encoding="utf-8")
    out = base / "out"
    summary = generate(asg, roster, out, jobs=2, progress=False)
    return load_assignment(asg), out, summary


def _text(path: Path, pages: slice = slice(None)) -> str:
    reader = pypdf.PdfReader(str(path))
    return "\n".join(p.extract_text() or "" for p in reader.pages[pages])


def _flat(text: str) -> str:
    return " ".join(text.replace("\xa0", " ").replace("−", "-").split())


_SCALE_NOTES = re.compile(r"(?:[\d.]+ (?:mm|cm|m|in) )?Scale \S+ — [\d.]+ \S+ on paper = [\d.]+ \S+"
                          r"|Suggested force scale: [\d.]+ \S+ = [\d.]+ \S+"
                          # how long the sheet asks a polygon's largest vector to be drawn (issue 25): no parameter
                          r"|largest vector [\d.]+ to [\d.]+ mm long")


# the answer table ("... on link 2 | lbf·in" is no published load of 2 lbf)
_TABLE = re.compile(r"Give these quantities in answers\.csv:.*?(?=Figures? \d+(?:–\d+)? of p\d+ follows?|$)")


def _sections(text: str, labels: list[str]) -> dict[str, str]:
    """The text of each problem's part of a document: from its heading to the next problem's."""
    starts = []
    for label in labels:
        m = re.search(rf"(?m)^{re.escape(label)}\. ", text)
        assert m, f"no heading for {label}"
        starts.append(m.start())
    assert starts == sorted(starts), "problems out of order"
    ends = starts[1:] + [len(text)]
    return {label: text[a:b] for label, a, b in zip(labels, starts, ends, strict=True)}


def _printed_values(item, variant) -> dict[str, set[float]]:
    """Every value each parameter symbol takes on the student's sheet (several for cases)."""
    pr = item.problem
    out: dict[str, set[float]] = defaultdict(set)
    for case in variant.result.cases:
        for name, value in case.values.items():
            par = pr.parameters.get(name)
            if par is not None and par.symbol:
                out[par.symbol].add(value)
    return out


def _same(printed: str, values: set[float]) -> bool:
    x = float(printed.replace("−", "-"))
    return any(math.isclose(x, float(fmt(v, 6)), rel_tol=1e-4, abs_tol=1e-9) or
               math.isclose(x, float(fmt(v, 4)), rel_tol=1e-3, abs_tol=1e-9) for v in values)


@pytest.mark.slow  # the whole bank for three students, with keys
def test_every_printed_parameter_is_the_students_own(whole_bank):
    asg, out, _ = whole_bank
    labels = [it.label for it in asg.items]
    checked = 0
    for sid in STUDENTS:
        sections = _sections(_text(out / "students" / sid / "assignment.pdf"), labels)
        for item in asg.items:
            v = student_variant(asg, item, sid)
            section = _SCALE_NOTES.sub(" ", _flat(sections[item.label]))  # the scale bar is no parameter
            printed = _printed_values(item, v)
            for sym, values in printed.items():
                for m in re.finditer(rf"(?<![\w]){re.escape(sym)} = ({NUMBER})", section):
                    assert _same(m.group(1), values), (
                        f"{sid} {item.label} ({item.problem.id}): prints {sym} = {m.group(1)}, "
                        f"the student's is {sorted(values)}")
                    checked += 1
            # no published value that differs from the student's, anywhere in the section (title,
            # source, statement, captions, figure): '120 lb' where the student's load is 150 lbf
            for name, par in item.problem.parameters.items():
                if par.value is None or par.expr or name not in v.result.values:
                    continue
                mine = {c.values[name] for c in v.result.cases}
                if any(math.isclose(par.value, x, rel_tol=1e-9) for x in mine):
                    continue
                stem = re.match(r"[^\W\d]+|°", units.pretty(par.unit) or "x").group(0)[:2]  # lbf: "lb"
                others = {fmt(x, 6) for c in v.result.cases for n, x in c.values.items()
                          if n in item.problem.parameters and units.pretty(item.problem.parameters[n].unit)
                          .startswith(stem)}
                pub = fmt(par.value, 6)
                if pub in others:
                    continue  # the student's own value of another parameter prints the same
                # a minus sign belongs to the number: −20 rad/s² is not the published 20 rad/s
                hit = re.search(rf"(?<![\w.\-−]){re.escape(pub)} ?{re.escape(stem)}", _TABLE.sub(" ", section))
                assert hit is None, (f"{sid} {item.label} ({item.problem.id}): the published {name} "
                                     f"= {pub} {stem} is printed: …{section[max(0, hit.start() - 60):hit.end() + 20]}…")
    assert checked > 100


@pytest.mark.slow  # the whole bank for three students, with keys
def test_every_figure_reference_is_a_caption_of_that_problem(whole_bank):
    asg, out, _ = whole_bank
    labels = [it.label for it in asg.items]
    for sid in STUDENTS:
        text = _text(out / "students" / sid / "assignment.pdf")
        captions = {int(n): lab for n, lab in re.findall(r"Figure[\s\xa0](\d+): (p\d+):", text)}
        assert sorted(captions) == list(range(1, len(captions) + 1)), "figures numbered in order"
        flat = _flat(text)
        assert "5.8A" not in flat and "5.9A" not in flat and "5.6A" not in flat
        for label, section in _sections(text, labels).items():
            refs = set()
            for a, b in re.findall(r"Figures? (\d+)(?:(?:–| and )(\d+))?", _flat(section)):
                refs.update(range(int(a), int(b or a) + 1))
            assert refs, f"{sid} {label}: the statement names no figure"
            for n in refs:
                assert captions.get(n) == label, f"{sid} {label} refers to Figure {n}, captioned {captions.get(n)}"


def test_figures_follow_the_assignment_order_and_cases(tmp_path, bank_ids):
    """Two problems swapped: each still names its own figure; a problem's positions stay in order."""
    ids = ["ch5-prob1", "ch5-ex5-3", "ch5-ex5-2"]
    asg = tmp_path / "a.yaml"
    asg.write_text(yaml.safe_dump(_assignment(ids, "swap"), sort_keys=False), encoding="utf-8")
    roster = tmp_path / "r.csv"
    roster.write_text("student_id,name\nq1,Q One\n", encoding="utf-8")
    generate(asg, roster, tmp_path / "out", keys=False, progress=False)
    text = _text(tmp_path / "out" / "students" / "q1" / "assignment.pdf")
    caps = re.findall(r"Figure[\s\xa0](\d+): (p\d+):[^\n]*?(?:position ([a-d]))?\.", text)
    assert [(int(n), lab, pos) for n, lab, pos in caps] == [
        (1, "p1", "a"), (2, "p1", "b"), (3, "p1", "c"), (4, "p1", "d"), (5, "p2", ""), (6, "p3", "")]
    flat = _flat(text)
    assert "offset slider crank of Figures 1–4" in flat
    assert "four-bar linkage of Figure 5 has" in flat and "four-bar linkage of Figure 6 has" in flat


@pytest.mark.slow  # the whole bank for three students, with keys
def test_titles_sources_and_grade_headers_hold_no_book_values(whole_bank):
    asg, out, _ = whole_bank
    for item in asg.items:
        p = item.problem
        for text in (p.title, p.source.get("ref", ""), p.source.get("document", "")):
            assert not re.search(r"\d+(\.\d+)? ?(lb|in|mm|N|°|rad)\b|=", text), (p.id, text)
            assert not re.search(r"Figure \d", text), (p.id, text)
            assert "seed" not in text, (p.id, text)


@pytest.mark.slow  # the whole bank for three students, with keys
def test_answer_points_are_readable_and_add_up(whole_bank):
    asg, out, _ = whole_bank
    rows = list(csv.DictReader((out / "key.csv").open(encoding="utf-8")))
    per: dict[tuple[str, str], float] = defaultdict(float)
    for r in rows:
        pts = float(r["points"])
        assert pts > 0 and (pts * 2) == int(pts * 2), f"{r['key']}: {pts} points is not a whole or half point"
        per[(r["student_id"], r["problem"])] += pts
    for item in asg.items:
        for sid in STUDENTS:
            assert per[(sid, item.label)] == item.points
    text = _flat(_text(out / "students" / STUDENTS[0] / "assignment.pdf"))
    assert "1.111" not in text and "0.8333" not in text


@pytest.mark.slow  # the whole bank for three students, with keys
def test_true_scale_figures_fit_and_state_their_scale(whole_bank):
    asg, out, summary = whole_bank
    assert not [w for w in summary.warnings if "wider" in w]
    for sid in STUDENTS:
        flat = _flat(_text(out / "students" / sid / "assignment.pdf"))
        stated = re.findall(r"Figures? (\d+)(?:–(\d+))? (?:is|are) drawn to scale (\d+:\d+)", flat)
        assert stated
        for a, b, ratio in stated:
            for n in range(int(a), int(b or a) + 1):
                assert re.search(rf"Figure {n}: p\d+: [^.]*(?:\.[^.]*)*?Drawn to scale {ratio}:", flat), (sid, n, ratio)
        # the scale bar's note prints the same ratio as the statement
        for ratio in {r for _, _, r in stated}:
            assert f"Scale {ratio} —" in flat


def test_a_drawing_too_wide_for_a_page_is_printed_at_a_smaller_stated_scale(tmp_path):
    from gradekit.figures.sheet import LANDSCAPE, printed_scale
    from gradekit.solving.sampling import variant

    pr = load_bank(ROOT / "problem_bank")["s003-slider-crank"]
    sid = next(f"w{i}" for i in range(200)
               if printed_scale(variant(pr, course="MEG373", salt="wide", student=f"w{i}").result) < 1.0)
    k = printed_scale(variant(pr, course="MEG373", salt="wide", student=sid).result)
    asg = tmp_path / "a.yaml"
    asg.write_text(yaml.safe_dump(_assignment(["s003-slider-crank"], "wide"), sort_keys=False), encoding="utf-8")
    roster = tmp_path / "r.csv"
    roster.write_text(f"student_id,name\n{sid},Wide Drawing\n", encoding="utf-8")
    summary = generate(asg, roster, tmp_path / "out", keys=False, progress=False)
    assert not summary.warnings
    flat = _flat(_text(tmp_path / "out" / "students" / sid / "assignment.pdf"))
    ratio = ratio_text(k)
    assert ratio in ("1:2", "1:5", "1:10")
    assert f"Figure 1 is drawn to scale {ratio}" in flat and f"Drawn to scale {ratio}:" in flat
    assert f"Scale {ratio} —" in flat and "Drawn to scale 1:1" not in flat
    reader = pypdf.PdfReader(str(tmp_path / "out" / "students" / sid / "assignment.pdf"))
    for page in reader.pages:  # nothing sticks out of any page
        assert float(page.mediabox.width) <= LANDSCAPE[0] + 200


@pytest.mark.slow  # the whole bank for three students, with keys
def test_combined_pdfs_name_each_student_and_keys_start_on_odd_pages(whole_bank):
    asg, out, _ = whole_bank
    def flat(items) -> list:
        return [x for o in items for x in (flat(o) if isinstance(o, list) else [o])]

    for name, what in (("assignments.pdf", ""), ("keys.pdf", "worked key, ")):
        reader = pypdf.PdfReader(str(out / name))
        tops = [o for o in reader.outline if not isinstance(o, list)]
        # each student's bookmark is their document's title
        assert [o.title for o in tops] == [f"MEG373 Every bank problem: {what}Student {s} ({s})" for s in STUDENTS]
        starts = [reader.get_destination_page_number(o) for o in tops]
        assert all(p % 2 == 0 for p in starts), f"{name}: students start on pages {[p + 1 for p in starts]}"
        nested = [flat(o) for o in reader.outline if isinstance(o, list)]
        assert len(nested) == len(STUDENTS)
        assert all(sum(bool(re.match(r"p\d+\. ", b.title)) for b in n) == len(asg.items) for n in nested)


@pytest.mark.slow  # the whole bank for three students, with keys
def test_keys_name_joints_as_printed_and_print_no_float_noise(whole_bank):
    asg, out, _ = whole_bank
    labels = [it.label for it in asg.items]
    for sid in STUDENTS:
        text = _text(out / "keys" / f"{sid}.pdf")
        assert not re.search(r"\d\.\d*0{8,}\d", text), "float noise printed"
        assert not re.search(r"\d[.,]\d{9,}", text), "float noise printed"
        sections = _sections(text, labels)
        for item in asg.items:
            p = item.problem
            printed = set(p.point_names.values())
            hidden = [n for n in p.point_names if n not in printed and n != p.point_names[n]]
            solved = sections[item.label].split("Solved forces", 1)[-1]
            for n in hidden:
                assert not re.search(rf"(?m)^{re.escape(n)} ", solved), f"{sid} {item.label}: joint named {n}"
            # each row of every "Solved forces" table starts with a point name printed on the sheet
            names = set(printed) | {n for n in v_points(asg, item, sid) if n not in p.point_names}
            for table in re.findall(r"Solved forces\nJoint Force[^\n]*\n(.*?)\nDriver:", sections[item.label], re.S):
                for row in table.splitlines():
                    if re.fullmatch(r"Page \d+", row.strip()) or "KEY" in row or row.startswith("Joint "):
                        continue  # the table goes on over a page break
                    first = row.split()[0]
                    joint = row.split()[2] if first == "slide" else first
                    assert joint in names, f"{sid} {item.label}: joint {joint!r} is no printed point ({sorted(names)})"
            if "Superposition" in sections[item.label]:
                assert "magnitudes, which do not add" in _flat(sections[item.label])


@pytest.mark.slow  # the whole bank for three students, with keys
def test_sheet_says_how_to_type_each_unit(whole_bank):
    """Each answer of answers.csv is asked on the sheet, and each unit the file spells differently
    from the sheet (N*m for N·m) is explained there."""
    asg, out, _ = whole_bank
    sid = STUDENTS[0]
    rows = list(csv.DictReader((out / "students" / sid / "answers.csv").open(encoding="utf-8")))
    flat = _flat(_text(out / "students" / sid / "assignment.pdf"))
    for r in rows:
        assert r["key"] in flat
    spelled = {r["unit"] for r in rows if units.pretty(r["unit"]) != r["unit"]}
    for u in spelled:
        assert f"{units.pretty(u)} is {u}" in flat, f"the sheet does not say how to type {u}"


def test_points_step_of_the_assignment_is_kept_in_key_csv(tmp_path):
    """`points_step: 1` gives whole answer points that add up to the problem's points."""
    data = _assignment(["ch5-ex5-3", "ch5-dyn-slider-crank"], "step")
    data["problems"][0]["points_step"] = 1
    data["problems"][1]["points"] = 7
    asg = tmp_path / "a.yaml"
    asg.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    roster = tmp_path / "r.csv"
    roster.write_text("student_id,name\nt1,T One\n", encoding="utf-8")
    out = tmp_path / "out"
    generate(asg, roster, out, keys=False, progress=False)
    rows = list(csv.DictReader((out / "key.csv").open(encoding="utf-8")))
    p1 = [float(r["points"]) for r in rows if r["problem"] == "p1"]
    p2 = [float(r["points"]) for r in rows if r["problem"] == "p2"]
    assert all(x == int(x) for x in p1) and sum(p1) == 10
    assert all(x * 2 == int(x * 2) for x in p2) and sum(p2) == 7
    sheet = _flat(_text(out / "students" / "t1" / "assignment.pdf"))
    assert "p1. Dynamic force analysis of a four-bar linkage" in sheet and "(7 points)" in sheet


@pytest.mark.slow  # the whole bank for three students, with keys
def test_no_heading_alone_at_a_page_foot_and_no_page_of_stragglers(whole_bank):
    asg, out, _ = whole_bank
    for sid in STUDENTS:
        for path in (out / "students" / sid / "assignment.pdf", out / "keys" / f"{sid}.pdf"):
            reader = pypdf.PdfReader(str(path))
            for n, page in enumerate(reader.pages, 1):
                lines = [x.strip() for x in (page.extract_text() or "").splitlines() if x.strip()]
                body = [x for x in lines if not re.fullmatch(r"Page \d+", x)]
                if n > 1:
                    body = body[1:]  # the running header
                assert body, f"{path.name} page {n} is empty"
                assert not re.match(r"p\d+\. ", body[-1]), f"{path.name} page {n} ends with the heading {body[-1]!r}"
                assert not body[-1].startswith(("Given values", "Solved forces", "Superposition", "Answers")), (
                    f"{path.name} page {n} ends with a heading whose table is on the next page")
                if n == len(reader.pages) and n > 1:
                    assert len(body) > 3 or any("Figure" in x for x in body), (
                        f"{path.name}: the last page holds only {body}")


def v_points(asg, item, sid) -> list[str]:
    """The internal point names of the student's linkage."""
    return list(student_variant(asg, item, sid).result.cases[0].solution.linkage.points)


@pytest.mark.slow  # the whole bank for three students, with keys
def test_key_statements_name_the_sheets_figures(whole_bank):
    asg, out, _ = whole_bank
    labels = [it.label for it in asg.items]
    sid = STUDENTS[1]
    sheet = _text(out / "students" / sid / "assignment.pdf")
    captions = {int(n): lab for n, lab in re.findall(r"Figure[\s\xa0](\d+): (p\d+):", sheet)}
    for label, section in _sections(_text(out / "keys" / f"{sid}.pdf"), labels).items():
        refs = re.findall(r"Figures? (\d+)(?:(?:–| and )(\d+))? of the sheet", _flat(section))
        assert refs, label
        for a, b in refs:
            for n in range(int(a), int(b or a) + 1):
                assert captions[n] == label
