"""Tolerance modes, angle wrap, scale floors, and where each answer's default comes from."""

from __future__ import annotations

import math

import pytest

from gradekit.bank.registry import load_bank
from gradekit.bank.schema import load_problem
from gradekit.keys import Tolerance
from gradekit.pipeline import published_values, solve_problem
from gradekit.tolerances import DEFAULTS, answer_kind

EX51 = "problem_bank/ch5_ex5_1_slider_crank_static.yaml"


def test_relative_with_absolute_floor():
    t = Tolerance("relative", 0.01, 0.5)
    assert t.accepts(101.0, 100.0) and not t.accepts(101.1, 100.0)
    assert t.accepts(0.4, 0.0) and not t.accepts(0.6, 0.0)  # the floor judges answers near zero
    assert not t.accepts(math.nan, 1.0) and not t.accepts(math.inf, 1.0)


def test_significant_figures_mode():
    t = Tolerance("sigfigs", 0.0, 0.0, 3)
    assert t.accepts(852.0, 852.36) and t.accepts(852.4, 852.36) and not t.accepts(853.0, 852.36)


def test_angles_wrap_at_360_degrees():
    t = Tolerance("relative", 0.0, 1.5, period=360.0)
    assert t.accepts(0.5, 359.5) and t.accepts(359.0, 0.2) and t.accepts(-0.5, 359.9)
    assert not t.accepts(2.0, 359.5)
    assert t.describe() == "±1.5°"


def test_floor_resolves_against_the_variant_scale():
    t = Tolerance("relative", 0.01, floor=0.03).resolve(200.0)
    assert t.abs == pytest.approx(6.0)
    assert t.accepts(5.0, 0.5)  # a small component of a 200 N problem is judged to ±6 N
    assert t.describe() == "±1 % (at least ±6)"


def test_answer_kinds():
    assert answer_kind("F[1,2].mag", "N") == "force"
    assert answer_kind("F[1,2].x", "lbf") == "force-component"
    assert answer_kind("driver", "N*mm") == "torque"
    assert answer_kind("aG[2].angle", "deg") == "angle"
    assert answer_kind("h[2]", "mm") == "length"
    assert answer_kind("alpha[2]", "rad/s**2") == "kinematic"
    assert all(DEFAULTS[(m, "angle")].period == 360 for m in ("analytical", "graphical"))


def test_measured_defaults_apply_and_explicit_tolerances_win(tmp_path):
    text = open(EX51, encoding="utf-8").read()
    measured = tmp_path / "measured"
    measured.mkdir()
    (measured / "ex51.yaml").write_text(text, encoding="utf-8")
    (measured / "_tolerances.yaml").write_text(
        "ch5-ex5-1:\n  F23: {rel: 0.0123, floor: 0.004, fr: 0.0, det: 100.0}\n", encoding="utf-8"
    )
    t = {a.key: a.tolerance for a in load_problem(measured / "ex51.yaml").answers}
    assert (t["F23"].rel, t["F23"].floor) == (0.0123, 0.004)  # the row beside the file
    assert t["T"] == DEFAULTS[("graphical", "torque")]  # no row: the per-kind default
    explicit = text.replace(
        'description: "connecting rod force at the piston pin C, magnitude"}',
        'description: "connecting rod force at the piston pin C, magnitude", tolerance: {rel: 0.002}}',
    )
    assert explicit != text
    (measured / "explicit.yaml").write_text(explicit, encoding="utf-8")
    tq = {a.key: a.tolerance for a in load_problem(measured / "explicit.yaml").answers}
    assert tq["F23"].rel == 0.002 and tq["F23"].floor == DEFAULTS[("graphical", "force")].floor  # explicit wins


def test_every_angle_answer_of_the_bank_wraps():
    for p in load_bank().values():
        r = solve_problem(p, published_values(p))
        for a in r.answers:
            if a.unit == "deg":
                assert a.tolerance.period == 360.0, (p.id, a.key)
                assert a.tolerance.accepts(a.value + 360.0, a.value)
