"""Every bank problem with printed answers reproduces them within the stated precision."""

from __future__ import annotations

import pytest

from gradekit import units
from gradekit.bank.registry import load_bank
from gradekit.pipeline import published_values, solve_problem

BANK = load_bank()
CASES = [(p.id, pub) for p in BANK.values() for pub in p.published]


def test_the_bank_has_published_examples():
    assert len(CASES) >= 10


@pytest.mark.parametrize(("pid", "pub"), CASES, ids=[f"{pid}:{pub.key}" for pid, pub in CASES])
def test_published_answer(pid, pub):
    problem = BANK[pid]
    result = solve_problem(problem, published_values(problem))
    answer = next(a for a in result.answers if a.key == pub.key)
    got = units.convert(answer.value, answer.unit, pub.unit) if answer.unit != pub.unit else answer.value
    assert got == pytest.approx(pub.value, rel=pub.rel), pub.note
    assert result.virtual_work_residual < 1e-9


@pytest.mark.parametrize("pid", sorted(BANK))
def test_published_version_solves_and_checks(pid):
    problem = BANK[pid]
    result = solve_problem(problem, published_values(problem))
    assert result.virtual_work_residual < 1e-9
    assert all(a.value == a.value for a in result.answers)  # no NaN
