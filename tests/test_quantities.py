"""The answer-quantity table: the grammar validation accepts, what the producer reports, in which unit."""

from __future__ import annotations

import pytest

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
