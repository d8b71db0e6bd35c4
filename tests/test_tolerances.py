"""Tolerance modes, angle wrap, scale floors, where each answer's default comes from, and the
bands the sampler judges draws by (stated in the problem file, never the measured table)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from quick import bank_params

from gradekit.bank.registry import bank_dir, load_bank
from gradekit.bank.schema import load_problem
from gradekit.cli import main
from gradekit.errors import GradekitError
from gradekit.solving.keys import Tolerance
from gradekit.solving.pipeline import published_values, solve_problem
from gradekit.solving.sampling import derive_seed, sample_many
from gradekit.solving.tolerances import answer_kind, defaults, from_row, to_row

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
    assert all(defaults()[(m, "angle")].period == 360 for m in ("analytical", "graphical"))


def test_measured_defaults_apply_and_explicit_tolerances_win(tmp_path):
    text = open(EX51, encoding="utf-8").read()
    stated_t = re.search(r"\n    T: \{[^}]*\}", text)
    assert stated_t
    text = text.replace(stated_t.group(0), "")  # T states no band
    measured = tmp_path / "measured"
    measured.mkdir()
    (measured / "ex51.yaml").write_text(text, encoding="utf-8")
    (measured / "_tolerances.yaml").write_text(
        "ch5-ex5-1:\n  F23: {rel: 0.0123, floor: 0.004, fr: 0.0, det: 100.0}\n", encoding="utf-8"
    )
    p = load_problem(measured / "ex51.yaml")
    t = {a.key: a.tolerance for a in p.answers}
    assert (t["F23"].rel, t["F23"].floor) == (0.0123, 0.004)  # the row beside the file
    assert t["T"] == defaults()[("graphical", "torque")]  # no row, no stated band: the per-kind default
    f03 = p.constraints.bands["F03"]
    assert (t["F03"].rel, t["F03"].abs, t["F03"].floor) == (f03.rel, f03.abs, f03.floor)  # no row: the stated band
    explicit = text.replace(
        'description: "connecting rod force at the piston pin C, magnitude"}',
        'description: "connecting rod force at the piston pin C, magnitude", tolerance: {rel: 0.002}}',
    )
    assert explicit != text
    (measured / "explicit.yaml").write_text(explicit, encoding="utf-8")
    tq = {a.key: a.tolerance for a in load_problem(measured / "explicit.yaml").answers}
    assert tq["F23"].rel == 0.002 and tq["F23"].floor == defaults()[("graphical", "force")].floor  # explicit wins


def test_every_angle_answer_of_the_bank_wraps():
    for p in load_bank().values():
        r = solve_problem(p, published_values(p))
        for a in r.answers:
            if a.unit == "deg":
                assert a.tolerance.period == 360.0, (p.id, a.key)
                assert a.tolerance.accepts(a.value + 360.0, a.value)


def test_per_kind_defaults_are_the_generated_table():
    table = yaml.safe_load((bank_dir() / "_tolerances.yaml").read_text(encoding="utf-8"))["_kind_defaults"]
    for method, kinds in table.items():
        for kind, row in kinds.items():
            assert defaults()[(method, kind)] == from_row(row), (method, kind)
    assert {k for _, k in defaults()} == {"angle", "force", "force-component", "torque", "kinematic", "length"}


EX53 = "problem_bank/ch5_ex5_3_fourbar_dynamic.yaml"


def _students(path, n=40):
    vb = sample_many(load_problem(path), course="MEG373", salt="hw", students=[f"s{i}" for i in range(n)])
    return {k: v.tolist() for k, v in vb.values.items()}, vb.draws.tolist()


def test_re_deriving_tolerances_changes_no_students_numbers(tmp_path):
    """The sampler judges draws by constraints.bands of the file: a different measured table (every
    band doubled, as a re-derivation might) leaves every student's values and draws as they were."""
    text = open(EX53, encoding="utf-8").read()
    measured = yaml.safe_load((bank_dir() / "_tolerances.yaml").read_text(encoding="utf-8"))
    for name, scale in (("same", 1.0), ("doubled", 2.0), ("halved", 0.5)):
        d = tmp_path / name
        d.mkdir()
        (d / "p.yaml").write_text(text, encoding="utf-8")
        rows = {
            k: {f: v * scale if f in ("rel", "deg", "floor") else v for f, v in r.items()}
            for k, r in measured["ch5-ex5-3"].items()
        }
        (d / "_tolerances.yaml").write_text(yaml.safe_dump({"ch5-ex5-3": rows}), encoding="utf-8")
    base = _students(tmp_path / "same" / "p.yaml")
    assert _students(tmp_path / "doubled" / "p.yaml") == base
    assert _students(tmp_path / "halved" / "p.yaml") == base
    stated = load_problem(EX53).constraints.bands
    assert stated["T"].rel > 0 and stated["aG2_dir"].period == 360.0


def test_stated_bands_are_validated(tmp_path):
    text = open(EX53, encoding="utf-8").read()
    stated = re.search(r"^    T: \{[^}]*\}$", text, re.M).group(0)  # T's band as the file states it
    for bad, where in (
        (stated, stated.replace("    T:", "    Tx:")),
        (stated, "    T: {rel: 2.5, floor: 0.03}"),
        (stated, "    T: {rel: 0.025, deg: 1}"),
    ):
        assert bad in text
        f = tmp_path / "bad.yaml"
        f.write_text(text.replace(bad, where), encoding="utf-8")
        with pytest.raises(GradekitError) as exc:
            load_problem(f)
        assert "constraints.bands" in str(
            exc.value.format_message() if hasattr(exc.value, "format_message") else exc.value
        )


def test_bank_check_fails_an_answer_graded_wider_than_its_draws_were_accepted_with(tmp_path):
    text = open(EX53, encoding="utf-8").read()
    old = "- {key: T, of: driver, unit: N*mm"
    assert old in text
    f = tmp_path / "wide.yaml"
    f.write_text(text.replace(old, old + ", tolerance: {rel: 0.0, abs: 100000, floor: 0.0}"), encoding="utf-8")
    r = CliRunner().invoke(main, ["bank", "check", str(f), "--variants", "20", "--class-size", "5"])
    assert r.exit_code == 1, r.output  # ±100,000 N·mm accepts a zero torque: a defect
    assert "T: graded at a band wider than the band its draws were accepted with" in r.output
    assert "a zero answer would be accepted" in r.output
    assert np.isfinite(load_problem(f).constraints.bands["T"].rel)


def test_every_bank_answer_is_graded_at_the_one_band_its_file_states():
    """One source per band: each answer states its band in constraints.bands (no explicit tolerance:
    beside it), and the bank loads exactly that band (the generated _tolerances.yaml row is a copy)."""
    table = yaml.safe_load((bank_dir() / "_tolerances.yaml").read_text(encoding="utf-8"))
    for p in load_bank().values():
        for a in p.answers:
            stated = p.constraints.bands.get(a.key)
            assert stated is not None and not a.tolerance_explicit, (p.id, a.key)
            t = a.tolerance
            widths = (t.rel, t.abs, t.floor, bool(t.period))
            assert widths == (stated.rel, stated.abs, stated.floor, bool(stated.period)), (p.id, a.key)
            assert from_row(table[p.id][a.key]) == stated, (p.id, a.key)


def test_a_row_keeps_an_absolute_part():
    band = Tolerance("relative", 0.1, 4.0, floor=0.05)
    assert from_row(to_row(band)) == band and to_row(band) == {"rel": 0.1, "floor": 0.05, "abs": 4.0}
    assert from_row(to_row(Tolerance("relative", 0.0, 1.25, period=360.0))).abs == 1.25


ZERO_VARIANTS = 200


@pytest.mark.parametrize("pid", bank_params(sorted(load_bank())))
def test_no_band_admits_a_zero_answer(pid):
    """Across drawn variants no grading band reaches zero: the sampler keeps only keys at least
    `gradable` stated bands from zero, so neither a zero nor a blank-as-zero answer is accepted
    (answers checked by hand are not graded automatically)."""
    p = load_bank()[pid]
    randoms = any(q.random for q in p.parameters.values())
    vb = sample_many(p, [derive_seed("MEG373", "zero", f"s{i}", pid) for i in range(ZERO_VARIANTS if randoms else 1)])
    assert vb.ok.all()
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        for a in batch.answer_list:
            if a.unit == "deg" or a.spec.hand_check:  # checked by hand: no band is applied
                continue
            value, scale = a.value[sel], a.scale[sel]
            assert (a.spec.tolerance.bands(value, scale) < np.abs(value)).all(), (a.key, value)
            assert not a.spec.tolerance.accepts_many(np.zeros_like(value), value, scale).any(), a.key
