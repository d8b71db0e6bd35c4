"""The tables' measured widths and heights (`documents.widths`) against Typst's own ``auto`` layout of
the same cells, for real worked keys and sheets: every column at least as wide as its widest cell
and at most `MARGIN` wider, every fixed row as tall as Typst makes it, no cell wrapped; a cell that
cannot be measured leaves its table ``auto``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import gradekit
from gradekit.bank.registry import load_bank
from gradekit.documents import context, widths
from gradekit.documents.context import _case
from gradekit.documents.typeset import Typ, available_fonts, render
from gradekit.documents.widths import MARGIN, cell, shape, table

ROOT = Path(__file__).resolve().parents[1]

ASSIGNMENT = """\
title: "Widths"
course: MEG373
salt: "widths"
problems:
  - {id: ch5-ex5-1, points: 10}
  - {id: ch5-ex5-3, points: 20}
  - {id: s004-case-study, points: 20}
"""


def _pt(spec: str) -> list[float | None]:
    """``(12.5pt, 1fr, auto,)`` -> [12.5, None, None]."""
    return [float(s[:-2]) if s.endswith("pt") else None for s in re.findall(r"[^(),\s]+", spec)]


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    """Every table of a class of two (sheets and worked keys), as `context` built them, plus the
    tables of each case of every problem of the bank, and the six-point matrix of a six-link
    mechanism solved analytically (the widest the key prints)."""
    base = tmp_path_factory.mktemp("widths")
    (base / "hw.yaml").write_text(ASSIGNMENT, encoding="utf-8")
    (base / "roster.csv").write_text("student_id,name\n1001,Ana\n1002,Zoë Łukasiewicz\n", encoding="utf-8")
    made = []

    def keep(cells, columns, align, **kw):
        t = table(cells, columns, align, **kw)
        made.append(((cells, columns, align, kw), t))
        return t

    mp = pytest.MonkeyPatch()
    mp.setattr(context, "table", keep)
    try:
        gradekit.generate(base / "hw.yaml", base / "roster.csv", base / "out", jobs=1)
        text = (ROOT / "problem_bank" / "s003_whitworth.yaml").read_text(encoding="utf-8")
        wide = base / "whitworth.yaml"
        wide.write_text(text.replace("method: graphical", "method: analytical"), encoding="utf-8")
        bank = load_bank(ROOT / "problem_bank")
        for problem in [gradekit.load_problem(wide), *(bank[pid] for pid in sorted(bank))]:
            res = gradekit.solve(problem)  # at its published values
            for case in res.cases:
                _case(res, case)
    finally:
        mp.undo()
    return made


def _typst(tmp_path: Path, checks: list[str]) -> list:
    """The value of each Typst expression of *checks* (evaluated in the documents' style, with
    ``size`` the text's size on the page)."""
    import typst

    style = render("_style.typ.j2", {"course": "", "title": "", "key": False, "fonts": available_fonts(),
                                     "student": {"name": "", "id": ""}})
    body = "".join(f"#layout(size => {c})\n" for c in checks)
    (tmp_path / "t.typ").write_text(style + body, encoding="utf-8")
    return json.loads(typst.query(str(tmp_path / "t.typ"), "<out>", field="value", root=str(tmp_path)))


def _table(cells, columns: str, inset: str, rows: str = "auto") -> str:
    body = ", ".join(f"[{c}]" for row in cells for c in row)
    return f"table(columns: {columns}, rows: {rows}, inset: {inset}, {body})"


def test_the_tables_are_measured(tables):
    kinds = {len(args[1]) for args, _ in tables}
    assert {3, 5, 6, 11, 17} <= kinds  # given, answers and sheet, forces, matrices of 7.5 and 6 pt
    assert all("auto" not in t.columns for _, t in tables)
    assert any(t.size == "6pt" for _, t in tables)


def test_columns_hold_their_widest_cell_and_rows_are_as_typst_makes_them(tables, tmp_path):
    checks = []
    for (cells, columns, _align, kw), t in tables:
        ix, iy = kw.get("inset", widths.INSET)
        plain = f"(x: {ix}pt, y: {iy}pt)"
        natural = [  # each column alone, as Typst sizes an auto column (the header bold, as printed)
            f"measure({_table([[row[c]] for row in cells], '(auto,)', plain)}).width / 1pt" if spec == "auto" else "0"
            for c, spec in enumerate(columns)]
        auto = _table(cells, "(" + ", ".join(columns) + ",)", plain)
        fixed = _table(cells, t.columns, t.inset, t.rows)
        unfixed = _table(cells, t.columns, t.inset)
        checks.append(f"text({t.size})[#context [#metadata((({', '.join(natural)},), "
                      + ", ".join(f"measure({x}, width: size.width).height / 1pt" for x in (auto, fixed, unfixed))
                      + ")) <out>]]")
    got = _typst(tmp_path, checks)
    assert len(got) == len(tables)
    for ((cells, columns, _a, _kw), t), (natural, auto_h, fixed_h, unfixed_h) in zip(tables, got, strict=True):
        computed = _pt(t.columns)
        for c, spec in enumerate(columns):
            if spec == "auto":
                assert natural[c] - 1e-6 <= computed[c] <= natural[c] + MARGIN, (c, cells[0])
        assert unfixed_h == pytest.approx(auto_h, abs=1e-6)  # no cell wraps in the fixed columns
        assert fixed_h == pytest.approx(auto_h, abs=1e-6)  # and the fixed rows are Typst's own


def test_a_cell_typst_cannot_measure_leaves_its_table_auto_and_costs_its_neighbours_nothing():
    t = table([[Typ("A"), Typ("B")], [cell("x"), Typ("#nosuchfunction()")]], ["auto", "auto"], ["left", "right"])
    assert (t.columns, t.rows, t.inset) == ("(auto, auto,)", "auto", "(x: 4pt, y: 3pt)")
    assert t.body == '  [A], [B], \n  [#"x"], [#nosuchfunction()], '
    again = table([[Typ("A"), Typ("B")], [cell("x"), cell("y")]], ["auto", "auto"], ["left", "right"])
    assert "auto" not in again.columns


def test_a_table_wider_than_the_text_keeps_auto_columns():
    wide = Typ("#h(300pt)")
    t = table([[Typ("A"), Typ("B")], [wide, wide]], ["auto", "auto"], ["left", "left"])
    assert (t.columns, t.rows) == ("(auto, auto,)", "auto")


def test_the_margin_is_inside_the_column_on_the_side_its_cells_leave_free():
    t = table([[Typ("Key"), Typ("Quantity"), Typ("Value")], [cell("a"), cell("b"), Typ("12.5")]],
              ["auto", "1fr", "auto"], ["left", "left", "right"])
    assert t.inset == ("((left: 4pt, right: 3.99pt, y: 3pt), (x: 4pt, y: 3pt), (right: 4pt, left: 3.99pt, y: 3pt),)")
    assert _pt(t.columns)[1] is None and t.rows.count("pt") == 2


def test_a_long_1fr_cell_keeps_its_row_auto():
    long = cell("a description that goes on " * 12)
    t = table([[Typ("Key"), Typ("Quantity")], [cell("a"), long], [cell("b"), cell("short")]],
              ["auto", "1fr"], ["left", "left"])
    rows = t.rows.strip("(),").split(", ")
    assert rows[1] == "auto" and rows[0].endswith("pt") and rows[2].endswith("pt")


def test_shapes_write_the_digits_of_text_as_0_and_leave_math_and_code():
    assert shape('−25.339 #"N"')[0] == '−00.000 #"N"'
    assert shape('*312540* #"mm/s²"')[0] == '*000000* #"mm/s²"'
    assert shape('#"±9.4e+03"')[0] == '#"±0.0e+00"'
    assert shape("#h(1em) 5")[0] == "#h(1em) 0"  # a call is a boundary: the text after it is text
    for same in ('$F_("01" x)$', '#raw("p1.F03")', '#"crank" #text(8pt)[(#"CCW 2")]', "_x_ 1", "*1"):
        assert shape(same) == (same, frozenset())
    _, needs = shape('340.1#"°"')
    assert needs == {(False, "."), (False, "°"), (False, "")}  # each neighbour of a digit, checked once


def test_a_digit_that_kerns_differently_is_measured_as_it_is(monkeypatch):
    m = widths._Measurer()
    monkeypatch.setattr(widths, "_measurer", lambda: m)
    style = 'text(10pt, weight: "regular")'
    m.sizes([(style, "1.5")])
    assert (style, "0.0") in m.sizes_of and (style, "1.5") not in m.sizes_of
    m.checked[(style, False, ".")] = False  # as if "1." kerned unlike "0."
    m.ok.clear()
    m.key_of.clear()
    m.sizes([(style, "7.5")])
    assert (style, "7.5") in m.sizes_of
