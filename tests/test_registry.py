"""One registry per way the project grows: a mechanism kind is declared once, in
gradekit/mechanics/mechanisms.py, and nothing else branches on its name."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from gradekit.mechanics.mechanisms import KINDS, Motion, build_many

PACKAGE = Path(__file__).resolve().parents[1] / "gradekit"


def test_no_module_but_the_registry_names_a_mechanism_kind():
    names = [k for k in KINDS if k != "crank"]  # "crank" is also a body and a geometry parameter
    pattern = re.compile("[\"'](" + "|".join(map(re.escape, names)) + ")[\"']")
    offenders = [
        f"{f.relative_to(PACKAGE)}:{i}"
        for f in PACKAGE.rglob("*.py")
        if f.name != "mechanisms.py"
        for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert offenders == []


@pytest.mark.parametrize("name", sorted(KINDS))
def test_a_kinds_declarations_name_its_own_points_bodies_and_parameters(name):
    k = KINDS[name]
    params = set(k.required) | set(k.optional)
    assert set(k.angles) <= params
    assert set(k.dimensions) <= params
    assert {p for seg in k.dimensions.values() for p in seg} <= set(k.points)
    assert set(k.bars) <= set(k.bodies)
    assert {p for segs in k.bars.values() for seg in segs for p in seg} <= set(k.points)
    assert not k.slotted or k.slotted in k.bodies
    assert set(k.loop) <= params and len(k.loop) in (0, 4)
    assert set(k.dead_centre) <= set(k.points)
    assert set(k.drivers) <= set(k.bodies)


@pytest.mark.parametrize("name", sorted(KINDS))
def test_a_kind_builds_the_bodies_and_points_it_declares(name):
    k = KINDS[name]
    rng = np.random.default_rng(3)
    params = {p: rng.uniform(0.05, 0.08) for p in k.required}
    params.update({"crank": 0.03, "ram_offset": 0.02})
    if name == "whitworth":
        params["frame"] = 0.015
    if name == "crank_shaper":
        params["frame"] = 0.1
    if name in ("slotted_lever", "crank_shaper", "whitworth"):
        params["lever"] = 0.2
    params = {p: v for p, v in params.items() if p in k.required}
    link = build_many(name, params, Motion(np.linspace(0.3, 2 * math.pi - 0.3, 40), 10.0), n=40)
    assert tuple(link.bodies) == k.bodies
    assert set(link.points) == set(k.points)
    assert link.refused.n == 40
