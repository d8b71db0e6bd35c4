"""Writing a new problem (issue 14): the tutorial's example passes `bank check` and reproduces its
published numbers and an independent closed form; `bank new` starters validate and solve for every
kind; docs/kinds.md is the registry's; and the format's own friction points give one clear error."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from gradekit.bank.schema import load_problem
from gradekit.bank.starter import kinds_reference, starter
from gradekit.cli import main
from gradekit.errors import ErrorList
from gradekit.mechanics.mechanisms import KINDS
from gradekit.solving.answers import published_mismatches
from gradekit.solving.pipeline import published_values, solve_problem
from gradekit.solving.sampling import sample_many

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "slider_crank_damper.yaml"


def run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def test_the_tutorial_example_passes_bank_check():
    r = run("bank", "check", str(EXAMPLE), "--variants", "100")
    assert r.exit_code == 0, r.output
    assert r.output.rstrip().endswith("bank check: all problems passed")


def test_the_tutorial_example_reproduces_its_published_numbers():
    p = load_problem(EXAMPLE)
    assert published_mismatches(solve_problem(p, published_values(p))) == []


def test_the_tutorial_example_is_the_closed_form_for_every_variant():
    """v_B = −r·ω·(sin θ + r·sin θ·cos θ / √(L² − r²·sin² θ)); the damper pushes the piston with −c·v_B
    and the gas load with −P, so the rod carries −(−c·v_B − P)/cos φ and T = (c·v_B² + P·v_B)/ω."""
    p = load_problem(EXAMPLE)
    vb = sample_many(p, range(40))
    v = {k: np.asarray(x, float) for k, x in vb.values.items()}
    r, length, th, w, c, load = v["r2"] / 1000, v["r3"] / 1000, np.radians(v["theta2"]), v["w2"], v["c"], v["P"]
    s = r * np.sin(th)
    v_b = -r * w * (np.sin(th) + s * np.cos(th) / np.sqrt(length**2 - s**2))
    rod = (c * -v_b - load) * -1 / np.cos(np.arcsin(s / length))
    ans = vb.answers
    np.testing.assert_allclose(ans["vB"], v_b, rtol=1e-12)
    np.testing.assert_allclose(ans["F34"], rod, rtol=1e-10)
    np.testing.assert_allclose(ans["T2"], (c * v_b**2 + load * v_b) / w, rtol=1e-10)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_bank_new_prints_a_starter_that_validates_and_solves(tmp_path, kind):
    r = run("bank", "new", kind)
    assert r.exit_code == 0
    assert r.output == starter(kind)
    f = tmp_path / f"{kind}.yaml"
    f.write_text(r.output, encoding="utf-8")
    res = solve_problem(load_problem(f), published_values(load_problem(f)))
    assert res.virtual_work_residual < 1e-9
    assert all(math.isfinite(a.value) and a.value != 0 for a in res.answers)


def test_bank_new_names_the_kind_it_did_not_find():
    r = CliRunner().invoke(main, ["bank", "new", "fourbr"])
    assert r.exit_code == 2
    assert "did you mean 'fourbar'" in r.output


def test_docs_kinds_is_generated_from_the_registry():
    assert (ROOT / "docs" / "kinds.md").read_text(encoding="utf-8") == kinds_reference()


def test_the_tutorial_runs_the_commands_it_shows():
    text = (ROOT / "docs" / "authoring.md").read_text(encoding="utf-8")
    assert "gradekit bank check examples/slider_crank_damper.yaml" in text
    assert "gradekit bank new slider_crank" in text


# ---- the format's friction points -------------------------------------------------------------

def _errors(tmp_path: Path, text: str) -> list[str]:
    f = tmp_path / "p.yaml"
    f.write_text(text, encoding="utf-8")
    with pytest.raises(ErrorList) as exc:
        load_problem(f)
    return [str(e) for e in exc.value.errors]


def _starter(kind: str = "fourbar") -> str:
    return starter(kind)


def test_a_misspelt_type_is_one_error_with_the_kind_meant(tmp_path):
    errors = _errors(tmp_path, _starter().replace("type: fourbar", "type: fourbr"))
    assert len(errors) == 1
    assert "mechanism.type" in errors[0] and "did you mean 'fourbar'" in errors[0]
    assert "slider_crank" in errors[0]


def test_an_unknown_point_link_or_joint_in_of_is_an_error_with_its_line(tmp_path):
    text = _starter().replace('of: "F[1,2].mag"', 'of: "v[Q].x"')
    errors = _errors(tmp_path, text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "v[Q].x" in t)
    assert f":{line}:" in errors[0] and "answers[1].of: expected a point as printed (A, B, O2, O4)" in errors[0]
    errors = _errors(tmp_path, _starter().replace('of: "F[1,2].mag"', 'of: "F[1,3].mag"'))
    assert len(errors) == 1 and "joined by a joint" in errors[0]
    errors = _errors(tmp_path, _starter().replace('.mag", unit: N,', '.mag", unit: N*m,'))
    assert len(errors) == 1 and "answers[1].unit: expected a unit of the same kind as N" in errors[0]


def test_an_unquoted_comma_in_a_flow_mapping_gets_a_hint(tmp_path):
    text = _starter().replace("description: the load}", "description: the load, along -x}")
    errors = _errors(tmp_path, text)
    assert len(errors) == 1 and "quote a value that has a comma" in errors[0]


def test_unit_presets_are_one_consistent_system(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text(_starter().replace("units: mm-N-s", "units: SI").replace("unit: mm,", "unit: m,")
                 .replace("value: 50, unit: m", "value: 0.05, unit: m")
                 .replace("value: 150, unit: m", "value: 0.15, unit: m")
                 .replace("value: 120, unit: m", "value: 0.12, unit: m")
                 .replace("value: 140, unit: m", "value: 0.14, unit: m"), encoding="utf-8")
    si = solve_problem(load_problem(f), published_values(load_problem(f)))
    base = load_problem_text(tmp_path, _starter())
    mm = solve_problem(base, published_values(base))
    assert si.answers["T"].value == pytest.approx(mm.answers["T"].value, rel=1e-12)
    assert load_problem(f).units["acceleration"] == "m/s**2"
    assert base.units["length"] == "mm" and base.units["acceleration"] == "mm/s**2"
    assert any("did you mean 'SI'" in e for e in _errors(tmp_path, _starter().replace("units: mm-N-s", "units: Si")))


def load_problem_text(tmp_path: Path, text: str, name: str = "q.yaml"):
    f = tmp_path / name
    f.write_text(text, encoding="utf-8")
    return load_problem(f)


def test_published_takes_abs_and_case_keys_and_blocks(tmp_path):
    text = _starter().replace("loads:", "cases:\n  a: {theta: 55}\n  b: {theta: \"crank + 20\"}\nloads:") + (
        "published:\n  answers:\n    T_a: {value: 0, unit: N*m, abs: 100}\n"
        "  cases:\n    b:\n      F12: {value: 0, unit: N, rel: 0, abs: 1000}\n"
    )
    p = load_problem_text(tmp_path, text)
    assert {(x.key, x.abs) for x in p.published} == {("T_a", 100.0), ("F12_b", 1000.0)}
    res = solve_problem(p, published_values(p))
    assert [c.values["theta"] for c in res.cases] == [55.0, 70.0]  # case b: crank + 20
    assert published_mismatches(res) == []
    errors = _errors(tmp_path, text.replace("abs: 100}", "rel: 0}"))
    assert any("rel > 0 or abs > 0" in e for e in errors)


def test_derived_parameters_without_a_printed_precision_keep_full_precision(tmp_path):
    text = _starter().replace("  theta:", '  third: {expr: "crank/3", unit: mm}\n  theta:')
    p = load_problem_text(tmp_path, text)
    res = solve_problem(p, published_values(p))
    assert res.values["third"] == 50 / 3  # not 16.6667
    text = text.replace('expr: "crank/3", unit: mm', 'expr: "crank/3", unit: mm, decimals: 2')
    p = load_problem_text(tmp_path, text, "r.yaml")
    assert solve_problem(p, published_values(p)).values["third"] == 16.67  # printed to 2 decimals: given so


def test_a_damper_at_an_ambiguous_pin_asks_which_body(tmp_path):
    text = _starter("slider_crank").replace(
        "loads:\n", "loads:\n  - {name: D, type: damper, between: [O2, B], c: 1}\n"
    ).replace("input: {theta: theta}", "input: {theta: theta, omega: 10}")
    errors = _errors(tmp_path, text)
    assert len(errors) == 1 and "joins rod, slider" in errors[0] and "bodies:" in errors[0]
    errors = _errors(tmp_path, text.replace("input: {theta: theta, omega: 10}", "input: {theta: theta}")
                     .replace("c: 1}", "c: 1, bodies: [ground, slider]}"))
    assert len(errors) == 1 and "crank speed" in errors[0]


def test_the_reference_lists_every_result_of_the_table():
    from gradekit.solving.quantities import QUANTITIES

    text = (ROOT / "docs" / "authoring.md").read_text(encoding="utf-8")
    for q in QUANTITIES:
        assert f"`{q.name}" in text, q.name


def test_an_unquoted_bracket_and_comma_in_a_flow_mapping_gets_a_hint(tmp_path):
    """`{key: F12, of: F[1,2].mag}` is not valid YAML: the error says where and what to quote."""
    from gradekit.bank.schema import load_problem
    from gradekit.errors import GradekitError

    text = _starter().replace('of: "F[1,2].mag"', "of: F[1,2].mag")
    assert "of: F[1,2].mag" in text
    f = tmp_path / "p.yaml"
    f.write_text(text, encoding="utf-8")
    line = 1 + text.splitlines().index(next(ln for ln in text.splitlines() if "of: F[1,2].mag" in ln))
    with pytest.raises(GradekitError) as err:
        load_problem(f)
    msg = err.value.format_message()
    assert msg.startswith(f"{f}:{line}: expected valid YAML")
    assert 'quote a value such as "F[1,2].mag"' in msg


def test_bank_check_reports_a_published_value_the_solver_does_not_reproduce(tmp_path):
    from click.testing import CliRunner

    from gradekit.cli import main

    text = (ROOT / "problem_bank" / "ch5_ex5_1_slider_crank_static.yaml").read_text(encoding="utf-8")
    old = "T: {value: -1.120, unit: N*m, rel: 0.003"
    assert old in text
    f = tmp_path / "p.yaml"
    f.write_text(text.replace(old, "T: {value: -1.320, unit: N*m, rel: 0.003"), encoding="utf-8")
    r = CliRunner().invoke(main, ["bank", "check", str(f), "--variants", "3", "--class-size", "3"])
    assert r.exit_code == 1
    assert "published: T: published -1.32 N*m, solved -1.118" in r.output  # Example 5.1: T = -1.118 N·m
