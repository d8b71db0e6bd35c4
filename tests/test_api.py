"""The Python API, as a notebook would use it."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import gradekit

ROOT = Path(__file__).resolve().parents[1]


def _fresh(code: str, **env) -> str:
    import os

    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env={**os.environ, **env}, cwd=ROOT
    )
    return out.stdout


def test_importing_gradekit_loads_no_heavy_library():
    loaded = json.loads(_fresh(
        "import json, sys, gradekit; "
        "print(json.dumps([m for m in ('numpy', 'matplotlib', 'click', 'typst', 'pint', 'yaml') if m in sys.modules]))"
    ))
    assert loaded == []


def test_a_figure_leaves_matplotlibs_backend_alone():
    out = _fresh(
        "import gradekit, matplotlib; gradekit.figure(gradekit.sample('ch5-ex5-1', seed=1)); "
        "print(matplotlib.get_backend())",
        MPLBACKEND="pdf",
    )
    assert out.strip() == "pdf"


def test_the_readme_sequence_solves_a_students_example_5_1():
    """Example 5.1 (in-line slider crank, gas force P on the piston along -x): by virtual work the
    drive torque is T = -P·r·sinθ·(1 + r·cosθ / √(l² − r²·sin²θ)), here at a student's values."""
    p = gradekit.load_problem("ch5-ex5-1")
    r = gradekit.solve(gradekit.sample(p, seed=2024))
    v = r.values
    rr, ll, th, force = v["r"] / 1000, v["l"] / 1000, math.radians(v["phi"]), v["P"]
    expected = -force * rr * math.sin(th) * (1 + rr * math.cos(th) / math.sqrt(ll**2 - (rr * math.sin(th)) ** 2))
    t = r.answers["T"]
    from gradekit import units

    assert units.convert(t.value, t.unit, "N*m") == pytest.approx(expected, rel=1e-12)
    assert r.checks["virtual_work_residual"] < 1e-9


def test_sample_many_and_solve_many_agree_with_one_at_a_time():
    p = gradekit.load_problem("ch5-ex5-3")
    vs = gradekit.sample_many(p, seeds=range(50))
    rs = gradekit.solve_many(vs)
    assert rs.ok.all() and rs.answers["T"].shape == (50,)
    for i in (0, 17, 49):
        one = gradekit.solve(gradekit.sample(p, seed=i))
        assert rs.answers["T"][i] == pytest.approx(one.answers["T"].value, rel=1e-12)


def test_solve_many_over_a_crank_turn():
    p = gradekit.load_problem("ch5-dyn-slider-crank")
    theta = p.inputs["theta"]
    rs = gradekit.solve_many(p, {theta: np.linspace(0.0, 350.0, 36)})
    assert rs.ok.all() and rs.answers["T"].shape == (36,)


def test_a_student_of_an_assignment_gets_their_sheets_values():
    v = gradekit.sample("ch5-ex5-3", student="1001", assignment=ROOT / "examples" / "hw5.yaml")
    from gradekit.assignment import load_assignment, student_variant

    asg = load_assignment(ROOT / "examples" / "hw5.yaml")
    item = next(it for it in asg.items if it.problem.id == "ch5-ex5-3")
    assert v.values == student_variant(asg, item, "1001").values


def test_an_unknown_figure_name_lists_the_choices():
    v = gradekit.sample("ch5-ex5-1")
    with pytest.raises(gradekit.errors.GradekitError, match="expected a figure name .*scene"):
        gradekit.figure(v, "nope")
