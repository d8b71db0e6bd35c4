"""The answer-quantity table: the grammar validation accepts, what the producer reports, in which unit."""

from __future__ import annotations

from pathlib import Path

import pytest

import gradekit
from gradekit import units
from gradekit.bank.registry import load_bank
from gradekit.solving import quantities
from gradekit.solving.sampling import variant
from gradekit.solving.tolerances import answer_kind

BANK = load_bank()


@pytest.mark.parametrize(
    ("of", "name", "component", "group"),
    [
        ("driver", "driver", "", ""),
        ("driver@P", "driver", "", "P"),
        ("F[3,2].mag", "F", "mag", ""),
        ("F[1,2]@inertia[2].x", "F", "x", "inertia[2]"),
        ("aG[2].angle", "aG", "angle", ""),
        ("h[3]", "h", "", ""),
        ("param[r1]", "param", "", ""),
    ],
)
def test_the_grammar_reads_every_form(of, name, component, group):
    asked = quantities.parse(of)
    assert (asked.quantity.name, asked.component, asked.group) == (name, component, group)


@pytest.mark.parametrize("of", ["driver.x", "h[3].mag", "F[3].mag", "aG[2].z", "Fx[1,2]", "param[r1].x", "alpha", ""])
def test_the_grammar_refuses_what_no_mechanism_reports(of):
    assert quantities.parse(of) is None


@pytest.mark.parametrize("pid", sorted(BANK))
def test_every_bank_answer_is_in_the_table_with_its_unit_and_kind(pid):
    p = BANK[pid]
    case = variant(p).result.cases[0]
    for a in p.answers:
        asked = quantities.parse(a.of)
        assert asked is not None, a.of
        if asked.kind:  # the table decides
            assert answer_kind(a.of, a.unit) == asked.kind
        else:  # the driver: a torque or a force, as its unit says
            by_unit = {units.si_unit("N*m"): "torque", units.si_unit("N"): "force"}[units.si_unit(a.unit)]
            assert answer_kind(a.of, a.unit) == by_unit
        if asked.quantity.name in ("param", "driver"):
            continue
        value, si = case.results[a.of]
        assert units.si_unit(si) == units.si_unit(asked.si)


@pytest.mark.parametrize("pid", sorted(BANK))
def test_every_result_a_solve_names_is_a_row_of_the_table_in_its_unit(pid):
    """The producers the rows declare name only what the grammar reads back, in the row's unit."""
    p = BANK[pid]
    derived = {a.of for a in p.answers if quantities.derived(a.of) is not None}
    seen = set()
    for case in variant(p).result.cases:
        for name, (_value, si) in case.results.items():
            if name in derived:
                continue
            asked = quantities.parse(name)
            assert asked is not None and quantities.name_of(asked) == name, name
            seen.add(asked.quantity.name)
            if asked.quantity.name == "driver":  # a torque, or a force for a slider driver
                assert si in ("N*m", "N"), name
            elif asked.quantity.name != "param":  # a parameter is in its own unit
                assert si == asked.si, name
    # every row but the ones a mechanism may lack (a sliding joint's couple, an asked parameter) is named
    assert seen >= {q.name for q in quantities.QUANTITIES} - {"M", "param"}



def test_a_parameter_asked_as_an_answer_is_its_own_value_in_each_case(tmp_path):
    bank_file = Path(BANK["ch5-prob1"].path)
    text = bank_file.read_text(encoding="utf-8").replace(
        "answers:\n", 'answers:\n  - {key: R, of: "param[r]", unit: in, description: crank length}\n'
        '  - {key: PHI, of: "param[phi]", unit: deg, description: crank angle}\n', 1
    )
    (tmp_path / bank_file.name).write_text(text, encoding="utf-8")
    v = gradekit.sample(gradekit.load_problem(tmp_path / bank_file.name), seed=3)
    got = {a.key: (a.value, a.unit) for a in gradekit.solve(v).answers}
    assert {k: got[f"R_{k}"] for k in "abcd"} == {k: (v.values["r"], "in") for k in "abcd"}
    assert [got[f"PHI_{k}"] for k in "abcd"] == [(45.0, "deg"), (135.0, "deg"), (270.0, "deg"), (315.0, "deg")]
