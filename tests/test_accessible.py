"""Documents every student can read (issue 28): figure descriptions written from the model, PDF/UA-1
sheets and keys, combined PDFs that keep the tags, and the sheet's HTML version.

The figure descriptions are checked over every bank problem through the public figure functions (no
PDF compiled): each value a figure labels is in its description, with its unit, and no answer of the
sheet is in a sheet figure's. The PDFs come from one small class generated once for this module.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pikepdf
import pytest
import yaml

from gradekit import figures
from gradekit.bank.registry import load_bank
from gradekit.documents import generate
from gradekit.documents.typeset import speak
from gradekit.numbers import fmt
from gradekit.solving.sampling import variant
from gradekit.statement import render_statement

ROOT = Path(__file__).resolve().parents[1]
BANK = load_bank(ROOT / "problem_bank")
NUMBER = re.compile(r"(?<![\w.])[−-]?\d+(?:\.\d+)?(?![\w.]*\d)")
SVG = "{http://www.w3.org/2000/svg}"


def _labels(svg: bytes) -> list[str]:
    """Every text line a gradekit SVG draws (a label, a title, a scale note)."""
    root = ET.fromstring(svg)
    lines = []
    for t in root.iter(f"{SVG}text"):
        spans = list(t.iter(f"{SVG}tspan"))
        lines += ["".join(s.itertext()) for s in spans] if spans else ["".join(t.itertext())]
    return [x for x in lines if x.strip()]


def _scenes(result):
    cases = [c.name for c in result.cases] if len(result.cases) > 1 else [None]
    scales = (False, True) if result.problem.figure.true_scale else (False,)
    return [(case, ts) for case in cases for ts in scales]


@pytest.mark.parametrize("pid", sorted(BANK))
def test_a_sheet_figure_describes_every_label_and_no_answer(pid):
    result = variant(BANK[pid]).result
    statement = render_statement(result.problem, result.values)
    for case, true_scale in _scenes(result):
        svg, alt = figures.scene_described(result, case, true_scale=true_scale)
        labels = _labels(svg)
        assert labels and alt.startswith("Kinematic diagram of a ")
        for label in labels:  # "OB = 30 mm", "P = 40 N at 210°", "θ = 45°", "T (ccw +)", "O"
            assert label in alt, f"{pid} {case}: the figure labels {label!r}, its description does not"
        printed = " ".join(labels) + " " + statement
        shown = set(NUMBER.findall(printed.replace("−", "-")))
        for a in result.answers:
            for sig in (3, 4, 5, 6):
                s = fmt(a.value, sig)
                if s.lstrip("-") in shown or len(s.lstrip("-").replace(".", "").lstrip("0")) < 3:
                    continue  # a value the sheet prints anyway, or too short to tell apart
                assert s not in NUMBER.findall(alt.replace("−", "-")), (
                    f"{pid} {case}: the description of a sheet figure gives the answer {a.key} = {s}")


@pytest.mark.parametrize("pid", sorted(BANK))
def test_a_key_figure_describes_every_force_and_how_its_polygon_closes(pid):
    result = variant(BANK[pid]).result
    described = figures.key_figures_described(result)
    assert described
    for slug, caption, svg, alt in described:
        assert alt and alt != caption, f"{pid} {slug}: no description of its own"
        if slug == "torque-cycle":  # a matplotlib plot: its description gives each marked position
            assert all(str(c.name) in alt for c in result.cases)
            continue
        for label in _labels(svg):
            assert label in alt, f"{pid} {slug}: the figure labels {label!r}, its description does not"
        if "force polygon" in caption or slug.startswith("group-"):
            assert "head to tail" in alt and "the polygon closes" in alt, (pid, slug)
        if slug.startswith("fbd-"):
            assert re.search(r"= [\d.]+ \S+ at .+?, pointing (up|down|to the)", alt), (pid, slug)


def test_a_formula_s_spoken_form():
    assert speak('T = −1.176 "N·m"') == "T equals minus 1.176 newton metres"
    assert speak('abs(arrow(a)_("B")) = 800 "m/s²"') == (
        "magnitude of vector a sub B equals 800 metres per second squared")
    assert speak('omega_("3") = 2.5 "rad/s", #h(0.6em) theta_("3") = 30 degree') == (
        "omega sub 3 equals 2.5 radians per second, theta sub 3 equals 30 degrees")
    assert speak('h_("2") = (I_(G "2")) / (m_("2"))') == "h sub 2 equals (I sub G 2) over (m sub 2)"


# --- one small class, generated once: PDF/UA-1 sheets and keys, combined PDFs, sheet.html ------------

NAMES = {"a1": "Ada <b>Lovelace</b> & \"Co\" #import $x^$", "a2": "X" * 3000}


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    base = tmp_path_factory.mktemp("accessible")
    asg = base / "a.yaml"
    asg.write_text(yaml.safe_dump({
        "title": "Accessible <i>sheets</i>", "course": "MEG373", "salt": "accessible",
        "bank": str(ROOT / "problem_bank"),
        "instructions": "Read <em>all</em> & answer.\n\nSecond paragraph.",
        "problems": [{"id": "ch5-ex5-1", "points": 10}, {"id": "s004-case-study", "points": 10}],
    }, sort_keys=False), encoding="utf-8")
    roster = base / "r.csv"
    roster.write_text("student_id,name\n" + "".join(f'{k},"{v.replace(chr(34), chr(34) * 2)}"\n'
                                                    for k, v in NAMES.items()), encoding="utf-8")
    out = base / "out"
    summary = generate(asg, roster, out, progress=False)
    assert not summary.warnings
    return out


def _elements(node):
    kids = node.get("/K")
    kids = list(kids) if isinstance(kids, pikepdf.Array) else [kids] if kids is not None else []
    for k in kids:
        if isinstance(k, pikepdf.Dictionary) and "/S" in k:
            yield k
            yield from _elements(k)


def _documents(out: Path) -> list[Path]:
    return [out / "students" / s / "assignment.pdf" for s in NAMES] + [out / "keys" / f"{s}.pdf" for s in NAMES]


def test_sheets_and_keys_are_pdf_ua_1_with_a_described_figure_and_formula(generated):
    for path in _documents(generated):
        with pikepdf.Pdf.open(path) as pdf:
            meta = pdf.open_metadata()
            assert meta.get("pdfuaid:part") == "1", path
            assert str(pdf.Root.Lang) == "en" and bool(pdf.Root.MarkInfo.Marked)
            assert "worked key" in str(meta.get("dc:title")) or path.name == "assignment.pdf"
            tags = list(_elements(pdf.Root.StructTreeRoot))
            kinds = [str(e.S) for e in tags]
            assert kinds.count("/H1") == 1 and kinds.index("/H1") < kinds.index("/H2")
            figures_ = [e for e in tags if e.S == "/Figure"]
            assert figures_ and all(len(str(e.Alt)) > 40 for e in figures_), path
            heads = [e for e in tags if e.S == "/THead"]
            assert heads and all(any(x.S == "/TH" for x in _elements(h)) for h in heads)
            if path.parent.name == "keys":
                formulas = [e for e in tags if e.S == "/Formula"]
                assert len(formulas) > 100 and all(str(e.Alt).strip() for e in formulas)
                assert any(" equals " in str(e.Alt) for e in formulas)


def test_combined_pdfs_keep_structure_language_and_a_bookmark_per_student(generated):
    for name in ("assignments.pdf", "keys.pdf"):
        with pikepdf.Pdf.open(generated / name) as pdf:
            assert str(pdf.Root.Lang) == "en" and bool(pdf.Root.MarkInfo.Marked)
            tree = pdf.Root.StructTreeRoot
            assert len(tree.K) == len(NAMES)
            assert all(e.S == "/Document" for e in tree.K)
            with pdf.open_outline() as outline:
                tops = [item.title for item in outline.root]
            assert len(tops) == len(NAMES)
            assert NAMES["a1"] in tops[0], (name, tops)


def test_sheet_html_is_well_formed_with_a_text_alternative_for_each_figure(generated):
    for sid, name in NAMES.items():
        page = (generated / "students" / sid / "sheet.html").read_text(encoding="utf-8")
        assert page.startswith("<!DOCTYPE html>\n")
        root = ET.fromstring(page.split("\n", 1)[1])  # polyglot markup: a strict XML parser reads it
        h = "{http://www.w3.org/1999/xhtml}"
        assert root.get("lang") == "en" and root.find(f"{h}head/{h}title").text
        ids = [e.get("id") for e in root.iter() if e.get("id")]
        assert len(ids) == len(set(ids))
        svgs = list(root.iter(f"{SVG}svg"))
        assert len(svgs) == 2  # one scene per problem
        for svg in svgs:
            assert svg.get("role") == "img"
            described = root.find(f".//*[@id='{svg.get('aria-labelledby')}']")
            assert described is not None and "Kinematic diagram" in "".join(described.itertext())
        for table in root.iter(f"{h}table"):
            assert [th.get("scope") for th in table.iter(f"{h}th")] == ["col"] * 5
        # text stays text: the name as written, never markup
        assert name in "".join(root.itertext())
        assert not list(root.iter(f"{h}b")) and not list(root.iter(f"{h}i")) and not list(root.iter(f"{h}em"))
        assert "Read <em>all</em> & answer." in "".join(root.itertext())


# --- strings from files reach the documents as text (issue 26 items 14 and 18) ----------------------


def _text_right_edges(path: Path) -> list[float]:
    """The right edge (points from the left) of every text run on page 1, by pypdf's text visitor."""
    import pypdf

    page = pypdf.PdfReader(str(path)).pages[0]
    edges = []

    def visit(text, cm, tm, font, size):
        if text.strip():
            # a run's width is not reported: its start plus its characters at most a font size wide
            edges.append(tm[4] * cm[0] + cm[4] + len(text.strip()) * (size or 10) * 0.5 * tm[0] * cm[0])

    page.extract_text(visitor_text=visit)
    return edges


def test_a_3000_character_name_wraps_inside_the_page(generated):
    import pypdf

    path = generated / "students" / "a2" / "assignment.pdf"
    width = float(pypdf.PdfReader(str(path)).pages[0].mediabox.width)
    text = pypdf.PdfReader(str(path)).pages[0].extract_text()
    assert "Student ID" in text and "X" * 40 in text
    assert max(_text_right_edges(path)) < width - 20  # nothing runs past the right margin


HOSTILE = 'Crank #import "@preview/cetz:0.3.0" #sys.version $x^$ *b* <l> @r \\ ]'


def _bank_with(tmp_path: Path, title: str, statement_tail: str = "") -> Path:
    """A copy of the bank whose ch5-ex5-1 has *title* and *statement_tail* appended to its statement."""
    import shutil

    bank = tmp_path / "bank"
    shutil.copytree(ROOT / "problem_bank", bank)
    path = bank / "ch5_ex5_1_slider_crank_static.yaml"
    data = path.read_text(encoding="utf-8")
    data = re.sub(r"(?m)^title: .*$", lambda m: "title: " + yaml.safe_dump(title, width=10**6).strip()
                  .removesuffix("\n...").strip(), data, count=1)
    if statement_tail:
        data = data.replace("statement: |", "statement: |\n  " + statement_tail, 1)
    path.write_text(data, encoding="utf-8")
    return bank


def _one_student(tmp_path: Path, bank: Path, keys: bool = True):
    asg = tmp_path / "a.yaml"
    asg.write_text(yaml.safe_dump({"title": "T", "course": "C", "salt": "s", "bank": str(bank),
                                   "problems": [{"id": "ch5-ex5-1", "points": 10}]}), encoding="utf-8")
    roster = tmp_path / "r.csv"
    roster.write_text("student_id,name\nq1,Q\n", encoding="utf-8")
    return generate(asg, roster, tmp_path / "out", keys=keys, progress=False)


def test_markup_in_a_problem_title_prints_as_written(tmp_path):
    import pypdf

    summary = _one_student(tmp_path, _bank_with(tmp_path, HOSTILE))
    assert not summary.warnings
    for path in (summary.assignments[0], summary.keys[0]):
        text = " ".join(p.extract_text() for p in pypdf.PdfReader(str(path)).pages)
        assert HOSTILE in " ".join(text.split()), path  # no import, no version, no math: the text itself
    page = (tmp_path / "out" / "students" / "q1" / "sheet.html").read_text(encoding="utf-8")
    assert "Crank #import &#34;@preview/cetz:0.3.0&#34; #sys.version $x^$ *b* &lt;l&gt; @r \\ ]" in page


def test_text_no_font_draws_is_a_warning_naming_the_file_and_field(tmp_path):
    from gradekit.documents.typeset import missing_glyphs

    # a letter of a script whose font this machine lacks (Ethiopic, Phoenician, Adlam, Old Italic)
    letter = next((c for c in "\u1230\U00010900\U0001E900\U00010300" if missing_glyphs(c)), "")
    summary = _one_student(tmp_path, _bank_with(tmp_path, f"Crank {letter}"), keys=False)
    if not letter:  # every one drawn: the sheet is PDF/UA-1 as any other
        assert not summary.warnings
        with pikepdf.Pdf.open(summary.assignments[0]) as pdf:
            assert pdf.open_metadata().get("pdfuaid:part") == "1"
        return
    assert len(summary.warnings) == 1
    msg = summary.warnings[0]
    assert msg.startswith(str(tmp_path / "bank" / "ch5_ex5_1_slider_crank_static.yaml") + ": title: ")
    assert "\n" not in msg and "tagged PDF, not PDF/UA-1" in msg
    assert summary.assignments[0].is_file()


def test_a_method_printed_in_a_statement_is_one_line_naming_the_file(tmp_path):
    from gradekit.errors import GradekitError

    with pytest.raises(GradekitError) as exc:
        _one_student(tmp_path, _bank_with(tmp_path, "Crank", "The split: {{ r.split }}."), keys=False)
    msg = exc.value.format_message()
    assert "\n" not in msg and "ch5_ex5_1_slider_crank_static.yaml" in msg and "statement" in msg
    assert "'split' printed as it is" in msg and "built-in method" not in msg


def test_sheet_html_reads_at_200_percent_zoom_without_horizontal_scrolling(generated):
    """Debian's chromium at a 1280-pixel window zoomed to 200 % (a 640-pixel CSS viewport, two device
    pixels a CSS pixel): no page scrolls sideways, the long name neither; every figure fits the width."""
    from test_web_helpers import browser

    with browser() as b:
        page = b.new_page(viewport={"width": 640, "height": 900}, device_scale_factor=2)
        for sid in NAMES:
            page.goto((generated / "students" / sid / "sheet.html").as_uri())
            width = page.evaluate("document.documentElement.clientWidth")
            assert page.evaluate("document.documentElement.scrollWidth") <= width, sid
            widths = page.evaluate(
                "[...document.querySelectorAll('svg, table')].map(e => e.getBoundingClientRect().right)")
            assert widths and max(widths) <= width, sid
