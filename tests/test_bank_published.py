"""Every bank problem with printed answers reproduces them within the stated precision."""

from __future__ import annotations

import math

import pytest

from gradekit import units
from gradekit.bank.registry import load_bank
from gradekit.pipeline import published_values, solve_problem
from gradekit.sampling import variant

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


@pytest.mark.parametrize("pid", sorted(BANK))
def test_fifty_students_get_sound_and_individual_variants(pid):
    problem = BANK[pid]
    seen = set()
    for i in range(50):
        v = variant(problem, course="MEG373", salt="t", student=f"s{i}")
        assert v.result.virtual_work_residual < 1e-9
        assert all(math.isfinite(a.value) for a in v.result.answers)
        seen.add(tuple(sorted(v.values.items())))
    if any(q.random for q in problem.parameters.values()):
        assert len(seen) >= 45  # individual values, before any class de-duplication
