"""Block sampling: many draws per generator in one call give, bit for bit, what one `draw` at a time gives,
and drawing several candidates per seed per round picks each seed's first acceptable draw, as a
one-draw-per-round loop would."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from gradekit.bank.model import Parameter
from gradekit.bank.registry import load_bank
from gradekit.solving.sampling import _Drawer, check, derive_seed, draw, published_values, round_display, sample_many

STEPPED = [
    Parameter("a", "mm", low=20.0, high=45.0, step=1.0),
    Parameter("b", "deg", low=0.0, high=355.0, step=5.0),
    Parameter("c", "N", low=0.5, high=2.5, step=0.05),
    Parameter("d", "kg", low=1.0, high=1.0, step=0.5),  # one value: a draw that consumes no bits
    Parameter("e", "mm", low=1.0, high=3.0e6, step=0.25),  # too many values for a table
    Parameter("f", "mm", low=0.0, high=9.0, step=0.1, decimals=1),
    Parameter("g", "", choices=(3.0, 7.5, 11.0)),
    Parameter("h", "", choices=(4.0,)),
]
UNIFORM = [
    Parameter("u", "mm", low=20.0, high=45.0),
    Parameter("v", "N", low=-3.5, high=1e4, sigfigs=4),
    Parameter("w", "deg", low=0.001, high=0.002, decimals=5),
]


def _one_at_a_time(randoms, rng, count):
    """What `sample_many` drew before blocks: one `draw` per parameter per round, rounded as printed."""
    return [[draw(p, rng) if p.choices else round_display(p, draw(p, rng)) for p in randoms] for _ in range(count)]


@pytest.mark.parametrize(
    "randoms",
    [STEPPED, UNIFORM, STEPPED[:3] + UNIFORM[:1] + STEPPED[6:7], UNIFORM[1:2]],
    ids=["stepped", "uniform", "mixed", "one"],
)
def test_a_block_of_draws_is_the_draws_one_at_a_time_bit_for_bit(randoms):
    drawer = _Drawer(randoms)
    seeds = [derive_seed("c", "s", str(i), "p") for i in range(60)]
    counts = np.array([1 + (i * 7) % 23 for i in range(60)])
    got = drawer.rows([np.random.default_rng(s) for s in seeds], counts)
    want = [
        row for s, c in zip(seeds, counts, strict=True) for row in _one_at_a_time(randoms, np.random.default_rng(s), c)
    ]
    assert got.tolist() == want
    # and the generator is left where the one-at-a-time draws leave it
    a, b = np.random.default_rng(seeds[0]), np.random.default_rng(seeds[0])
    drawer.rows([a], np.array([5]))
    _one_at_a_time(randoms, b, 5)
    assert a.integers(1 << 40, size=4).tolist() == b.integers(1 << 40, size=4).tolist()
    assert a.random() == b.random()


def test_integer_ranges_that_often_reject_draw_alike():
    """Lemire's bounded draw rejects often for ranges near 2**32: a block still matches one call per value."""
    randoms = [
        Parameter("x", "", low=0.0, high=3.0 * 2**30 - 1, step=1.0),
        Parameter("y", "", low=0.0, high=2.0, step=1.0),
    ]
    drawer = _Drawer(randoms)
    for seed in range(20):
        got = drawer.rows([np.random.default_rng(seed)], np.array([40]))
        assert got.tolist() == _one_at_a_time(randoms, np.random.default_rng(seed), 40)


def _reference(problem, seed, max_draws):
    """One seed drawn one candidate at a time, each checked alone: (values, draws, rejections)."""
    randoms = [p for p in problem.parameters.values() if p.random]
    rng = np.random.default_rng(seed)
    rejected: Counter = Counter()
    for attempt in range(1, max_draws + 1):
        values = dict(published_values(problem))
        values.update(zip((p.name for p in randoms), _one_at_a_time(randoms, rng, 1)[0], strict=True))
        reason, result = check(problem, values)
        if reason is None and result is not None:
            return {p.name: values[p.name] for p in randoms}, attempt, Counter()
        rejected[reason or "unknown"] += 1
    return None, max_draws, rejected


@pytest.mark.parametrize("pid", ["s003-fourbar-quick-return", "ch5-ex5-3", "ch5-ex5-1"])
@pytest.mark.parametrize("max_draws", [3, 400])
def test_several_candidates_per_round_pick_each_seeds_first_acceptable_draw(pid, max_draws):
    problem = load_bank()[pid]
    seeds = [derive_seed("bank-check", "", str(i), pid) for i in range(8)]
    vb = sample_many(problem, seeds, max_draws=max_draws)
    for i, seed in enumerate(seeds):
        values, draws, rejected = _reference(problem, seed, max_draws)
        assert int(vb.draws[i]) == draws
        assert bool(vb.ok[i]) == (values is not None)
        if values is None:
            assert vb.failures[i] == rejected
        else:
            assert {k: float(vb.values[k][i]) for k in values} == values
