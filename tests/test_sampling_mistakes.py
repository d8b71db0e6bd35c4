"""The catalogued mistakes of some variants of a batch (the sampler's candidates not yet rejected) are,
bit for bit, what re-solving the whole batch gives them; the others are re-solved when asked for."""

from __future__ import annotations

import numpy as np
import pytest

from gradekit.bank.registry import load_bank
from gradekit.solving.mistakes import mistakes_many
from gradekit.solving.pipeline import solve_many
from gradekit.solving.sampling import sample_many


@pytest.mark.parametrize("pid", ["ch5-ex5-3", "s004-case-study", "s002-fourbar-matrix"])
def test_mistakes_of_some_rows_are_those_of_the_whole_batch(pid):
    problem = load_bank()[pid]
    vb = sample_many(problem, range(40))
    values = {k: v.copy() for k, v in vb.values.items()}
    whole = mistakes_many(solve_many(problem, values, 40), values)
    batch = solve_many(problem, values, 40)
    some = np.arange(40) % 3 == 1
    part = mistakes_many(batch, values, rows=some)
    assert [[m.name for m in ms] for ms in part.values()] == [[m.name for m in ms] for ms in whole.values()]
    resolved = {"static-answer", "no-inertia-torque", "no-gravity"}
    assert any(m.name in resolved for ms in part.values() for m in ms)
    for key, ms in part.items():
        for m, w in zip(ms, whole[key], strict=True):
            assert m.value[some].tobytes() == w.value[some].tobytes()
            assert (m.changed[some] == w.changed[some]).all()
            if m.name in resolved:  # not re-solved yet
                assert np.isnan(m.value[~some]).all() and not m.changed[~some].any()
    again = mistakes_many(batch, values)  # the rest, on request
    assert again is part
    for key, ms in again.items():
        for m, w in zip(ms, whole[key], strict=True):
            assert m.value.tobytes() == w.value.tobytes()
            assert (m.changed == w.changed).all()
