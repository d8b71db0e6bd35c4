"""Per-student values: deterministic, rounded as printed, distinct across a class, pinned for one student."""

from __future__ import annotations

import math

import pytest

from gradekit.bank.schema import load_problem
from gradekit.errors import SamplingError
from gradekit.solving.sampling import class_variants, derive_seed, variant

EX51 = "problem_bank/ch5_ex5_1_slider_crank_static.yaml"


def test_seed_is_sha256_of_the_identifiers():
    """The seed is the first 8 bytes (big-endian) of SHA-256 of course, salt, student and problem id joined
    by the unit separator, and the re-draw counter after them when it is not 0."""
    import hashlib

    def sha(*parts: str) -> int:
        return int.from_bytes(hashlib.sha256("\x1f".join(parts).encode("utf-8")).digest()[:8], "big")

    assert derive_seed("MEG373", "hw5", "1001", "ch5-ex5-1") == sha("MEG373", "hw5", "1001", "ch5-ex5-1")
    assert derive_seed("MEG373", "hw5", "1001", "ch5-ex5-1", redraw=2) == sha("MEG373", "hw5", "1001", "ch5-ex5-1", "2")
    a = derive_seed("MEG373", "hw5", "1001", "ch5-ex5-1")
    assert a == derive_seed("MEG373", "hw5", "1001", "ch5-ex5-1")
    assert a != derive_seed("MEG373", "hw5", "1002", "ch5-ex5-1")
    assert a != derive_seed("MEG373", "hw6", "1001", "ch5-ex5-1")
    assert a != derive_seed("MEG373", "hw5", "1001", "ch5-ex5-1", redraw=1)


def test_pinned_values_of_one_known_student():
    """Same student -> same values on any machine (SHA-256 + numpy PCG64); changing this is a breaking change."""
    p = load_problem(EX51)
    v = variant(p, course="MEG373", salt="hw5", student="s001")
    assert v.values == {"r": 33.0, "l": 105.0, "phi": 65.0, "P": 45.0}
    # its answers from the closed form (sin β = r·sin φ / l): F03 = P·tan β, F23 = P/cos β,
    # T = -P·r·sin(φ+β)/cos β in N·m
    beta = math.asin(33.0 * math.sin(math.radians(65)) / 105.0)
    exact = {"F03": 45 * math.tan(beta), "F23": 45 / math.cos(beta),
             "T": -45 * 0.033 * math.sin(math.radians(65) + beta) / math.cos(beta)}
    assert {a.key: a.value for a in v.result.answers} == pytest.approx(exact, rel=1e-12)


def test_values_are_rounded_as_printed_and_inside_ranges():
    p = load_problem(EX51)
    for i in range(50):
        v = variant(p, course="MEG373", salt="x", student=f"s{i}")
        for name, value in v.values.items():
            par = p.parameters[name]
            assert par.low <= value <= par.high
            assert abs(value / par.step - round(value / par.step)) < 1e-9


def test_published_variant_uses_the_printed_values():
    p = load_problem(EX51)
    v = variant(p)
    assert v.values == {"r": 30, "l": 70, "phi": 45, "P": 40}


def test_a_class_of_300_gets_300_distinct_variants_and_redraw_touches_no_one_else():
    p = load_problem(EX51)
    ids = [f"{1000 + i}" for i in range(300)]
    cls = class_variants(p, "MEG373", "hw5", ids)
    assert len({tuple(sorted(v.values.items())) for v in cls.values()}) == 300
    again = class_variants(p, "MEG373", "hw5", ids)
    assert all(again[s].values == cls[s].values for s in ids)
    # re-drawing one student changes that student only
    redrawn = variant(p, course="MEG373", salt="hw5", student="1005", redraw=cls["1005"].redraw + 1)
    assert redrawn.values != cls["1005"].values
    for s in ids:
        if cls[s].redraw == 0:
            assert variant(p, course="MEG373", salt="hw5", student=s).values == cls[s].values


def test_impossible_constraints_name_the_constraint_that_rejected_most(tmp_path):
    text = open(EX51, encoding="utf-8").read().replace('l >= 2.2*r', 'l >= 20*r')
    f = tmp_path / "bad.yaml"
    f.write_text(text, encoding="utf-8")
    p = load_problem(f)
    with pytest.raises(SamplingError, match=r"constraint 'require: the rod is at least 2.2 times the crank'"):
        variant(p, student="x", max_draws=50)


def test_every_drawn_answer_is_gradable_and_listed_mistakes_are_distinguishable():
    from gradekit.bank.registry import load_bank
    from gradekit.solving.mistakes import catalogued_mistakes

    """The sampler's guarantees hold at the bands the problem file states (constraints.bands):
    every answer two bands from zero, each declared mistake two bands from the key. (The grading
    band may be wider where honest work needs it; bank check reports what that costs.)"""
    p = load_bank()["ch5-ex5-3"]
    assert dict(p.constraints.distinguish) == {"static-answer": ("T",), "no-inertia-torque": ("T",)}
    stated = p.constraints.bands
    for i in range(20):
        v = variant(p, course="MEG373", salt="t", student=f"g{i}")
        scales = {a.key: a.scale for a in v.result.answers}
        for a in v.result.answers:
            if a.unit != "deg" and a.key in stated:
                assert abs(a.value) >= 2 * stated[a.key].resolve(scales[a.key]).band(a.value)
        t = next(a for a in v.result.answers if a.key == "T")
        band_t = stated["T"].resolve(t.scale).band(t.value)
        found = {m.name: m.value for m in catalogued_mistakes(v)["T"]}
        for name in ("static-answer", "no-inertia-torque"):
            assert abs(found[name] - t.value) >= 2 * band_t


def test_distinguish_names_unknown_answers_and_mistakes(tmp_path):
    text = open(EX51, encoding="utf-8").read().replace(
        "  dead_centre_min: 20\n", "  dead_centre_min: 20\n  distinguish: {no-gravity: [T, Q], typo: [T]}\n")
    f = tmp_path / "d.yaml"
    f.write_text(text, encoding="utf-8")
    from gradekit.errors import ErrorList

    with pytest.raises(ErrorList) as err:
        load_problem(f)
    msg = err.value.format_message()
    assert "constraints.distinguish.no-gravity: expected a list of answer keys among F03, F23, T; got ['T', 'Q']" in msg
    assert "constraints.distinguish.typo: expected one of" in msg


def test_a_gradable_failure_names_the_answer_too_small_to_grade(tmp_path):
    """Every draw rejected because an answer sits too near zero: the error names that answer."""
    text = open(EX51, encoding="utf-8").read()
    text = text.replace("  dead_centre_min: 20\n", "  dead_centre_min: 20\n  gradable: 1000\n")
    f = tmp_path / "g.yaml"
    f.write_text(text, encoding="utf-8")
    with pytest.raises(SamplingError) as err:
        variant(load_problem(f), course="MEG373", salt="t", student="1", max_draws=5)
    assert "constraint 'gradable: F23'" in err.value.format_message()  # F03 and T are checked by hand
