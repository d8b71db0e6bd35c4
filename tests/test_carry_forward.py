"""Error carried forward (gradekit.solving.carry): dependencies derived from the model, and later answers
recomputed from a student's own earlier ones, checked against independent full solves."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import gradekit
from gradekit.bank.registry import load_bank
from gradekit.solving import carry, quantities
from gradekit.solving.keys import Tolerance

BANK = load_bank()
DYNAMIC = ("ch5-ex5-3", "ch5-dyn-slider-crank", "s004-case-study")
SEEDS = (None, 7, 11)  # the published variant and two students'


def _variant(pid: str, seed):
    p = BANK[pid]
    return p, gradekit.sample(p, seed=seed)


def _misread(p, v, name: str, factor: float = 1.1):
    """The answers of a student who solved the same problem consistently with *name* × *factor*:
    a full independent solve, the geometry unchanged."""
    return gradekit.solve(p, {**v.values, name: v.values[name] * factor})


def _close(c: carry.Carried, value: float) -> bool:
    if c.unit == "deg":
        return abs((c.value - value + 180.0) % 360.0 - 180.0) <= 1e-7
    return abs(c.value - value) <= 1e-9 * max(abs(value), 1e-12)


def _asked_of_body(p, answers) -> dict[str, set[str]]:
    """Link label -> the keys asking one of its kinematic or inertia quantities (aG, α, Fi, Ci, h)."""
    out: dict[str, set[str]] = {}
    for a in answers:
        asked = quantities.parse(a.of)
        if asked is not None and not asked.group and asked.quantity.name in ("aG", "alpha", "Fi", "Ci", "h"):
            out.setdefault(asked.args, set()).add(a.key)
    return out


def _inertia_held(dep: carry.Dependency) -> list[str]:
    return [h for h in dep.held if h.startswith("inertia[")]


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("pid", DYNAMIC)
def test_a_student_who_misread_the_crank_speed_is_carried_on_every_later_answer(pid, seed):
    """ω read 10 % high and worked on consistently: every inertia and force answer equals the
    recomputation from the student's own kinematics (or inertia answers), the kinematics carry nothing."""
    p, v = _variant(pid, seed)
    student = _misread(p, v, p.inputs["omega"])
    submitted = {a.key: a.value for a in student.answers}
    deps = carry.dependencies(v.result)
    got = carry.carried(v.result, submitted)
    again = carry.plan(v.result).recompute(submitted)
    credited = carry.credited(v.result, submitted)
    key = {a.key: a for a in v.result.answers}
    later = [a for a in student.answers if deps[a.key].stage not in ("given", "kinematics")]
    assert later
    for a in student.answers:
        dep = deps[a.key]
        if dep.stage == "kinematics":
            assert a.key not in got and not dep.carriable
            continue
        assert dep.carriable, (a.key, dep.reason)
        if _inertia_held(dep):
            # its value also depends on a link whose motion the problem never asks (here the crank's
            # own inertia force): kept exact, so a misread ω is not carried into it
            asked = _asked_of_body(p, v.result.answers)
            assert all(h[len("inertia["):-1] not in asked for h in _inertia_held(dep)), (a.key, dep.held)
            continue
        c = again[a.key]
        assert _close(c, a.value), (a.key, c.value, a.value)
        assert c.accepts(a.value) and all(u.key in dep.upstream for u in c.used)
        # carried where an upstream value used is wrong (an a_C near zero may be right within its floor)
        assert (a.key in got) == bool(c.wrong), a.key
        if a.key in got and not key[a.key].tolerance.accepts(a.value, key[a.key].value):
            assert a.key in credited
    assert set(credited) <= set(got) and len(got) >= len(later) // 2


@pytest.mark.parametrize("pid", DYNAMIC)
def test_forces_follow_the_kinematics_where_the_inertia_answers_are_blank(pid):
    p, v = _variant(pid, 3)
    student = _misread(p, v, p.inputs["omega"])
    deps = carry.dependencies(v.result)
    submitted = {a.key: a.value for a in student.answers if deps[a.key].stage != "inertia"}
    got = carry.carried(v.result, submitted)
    for a in student.answers:
        dep = deps[a.key]
        if dep.stage in ("forces", "total") and not _inertia_held(dep):
            assert _close(got[a.key], a.value), a.key
            assert {u.key for u in got[a.key].used}.isdisjoint(k for k, d in deps.items() if d.stage == "inertia")


STAGED = [(pid, stage) for pid in DYNAMIC for stage in ("inertia", "forces")
          if stage in {d.stage for d in carry.dependencies(gradekit.solve(BANK[pid])).values()}]


@pytest.mark.parametrize("pid, stage", STAGED)
def test_later_answers_inconsistent_with_the_students_own_earlier_ones_earn_nothing(pid, stage):
    """ω misread and the kinematics worked on consistently; the answers of one later *stage* are
    3-8 of their bands off what the student's own kinematics give (the other later answers left
    blank, so the reference is the independent ω × 1.1 solve): none is credited."""
    p, v = _variant(pid, 5)
    student = _misread(p, v, p.inputs["omega"])
    deps = carry.dependencies(v.result)
    tol = {a.key: a.tolerance for a in v.result.answers}
    rng = np.random.default_rng(12)
    submitted = {}
    for a in student.answers:
        if deps[a.key].stage in ("given", "kinematics"):
            submitted[a.key] = a.value
        elif deps[a.key].stage == stage:
            band = max(tol[a.key].rel * abs(a.value), tol[a.key].abs)
            submitted[a.key] = a.value + rng.uniform(3.0, 8.0) * rng.choice([-1.0, 1.0]) * band
    got = carry.carried(v.result, submitted)
    assert any(deps[k].stage == stage for k in got)  # the upstream is wrong: there is a recomputation
    assert carry.credited(v.result, submitted) == {}
    assert not any(c.accepts(submitted[k]) for k, c in got.items() if k in submitted)


@pytest.mark.parametrize("pid", sorted(BANK))
def test_the_exact_upstream_values_recompute_the_key_and_carry_nothing(pid):
    """Submitting the key itself: every recomputation is the key (the unit responses and the
    model's own superposition agree with the solver), and nothing is carried."""
    r = gradekit.solve(BANK[pid])
    key = {a.key: a.value for a in r.answers}
    again = carry.plan(r).recompute(key)
    for k, c in again.items():
        assert _close(c, key[k]), (k, c.value, key[k])
        assert not c.wrong
    assert carry.carried(r, key) == {}
    assert carry.carried(r, {}) == {}


@pytest.mark.parametrize("pid", sorted(BANK))
def test_every_answer_has_a_stage_and_no_force_misses_an_asked_inertia_upstream(pid):
    """Derived from the model, for every bank problem: kinematics carry nothing; an answer that
    cannot be carried says why; a force that the solver says changes with a link's inertia lists
    that link's asked kinematic or inertia answers among its upstream ones."""
    p = BANK[pid]
    r = gradekit.solve(p)
    deps = carry.dependencies(r)
    assert list(deps) == [a.key for a in r.answers]
    asked_of = _asked_of_body(p, r.answers)
    for a in r.answers:
        dep = deps[a.key]
        assert dep.stage in carry.STAGES and dep.key == a.key
        assert dep.carriable == (not dep.reason) and dep.carriable == bool(dep.upstream)
        if dep.stage == "kinematics":
            assert not dep.carriable
        asked = quantities.parse(a.of)
        if p.analysis != "dynamic" or asked is None or asked.group or dep.stage not in ("forces", "total"):
            continue
        case = next(c for c in r.cases if c.name == a.case)
        stem = quantities.name_of(quantities.Asked(asked.quantity, asked.args, "", ""))

        names = [stem + ".x", stem + ".y"] if asked.quantity.vector else [stem]
        total = np.array([case.results[n][0] for n in names])
        each = {  # the solver's own superposition part of each link's inertia
            p.label(g.split(":", 1)[1]): np.array(
                [case.results[n.replace(stem, f"{stem}@inertia[{p.label(g.split(':', 1)[1])}]", 1)][0] for n in names])
            for g in case.solution.groups if g.startswith("inertia:")
        }
        size = max(np.abs(total).max(), max(np.abs(x).max() for x in each.values()))
        for k, x in each.items():
            if np.abs(x).max() > 1e-6 * size and k in asked_of:
                assert asked_of[k] & set(dep.upstream), (a.key, k, dep.upstream)


def _load_parameter(p):
    """The first load whose magnitude is a parameter (what a student can misread), or None."""
    return next((ld for ld in p.loads if isinstance(ld.magnitude, str) and ld.magnitude in p.parameters), None)


STATIC = sorted(pid for pid, p in BANK.items() if p.analysis == "static" and _load_parameter(p) is not None)


@pytest.mark.parametrize("pid", STATIC)
def test_a_static_problem_carries_only_superposition_totals_from_their_parts(pid):
    """A student who misread one load (×1.1): their parts of that load are wrong; a total is
    carried from their parts (the exact part of any load they were not asked for), and nothing
    else is; every answer that is not carried says why."""
    p = BANK[pid]
    load = _load_parameter(p)
    v = gradekit.sample(p, seed=4)
    student = _misread(p, v, load.magnitude)
    deps = carry.dependencies(v.result)
    submitted = {a.key: a.value for a in student.answers}
    got = carry.carried(v.result, submitted)
    again = carry.plan(v.result).recompute(submitted)
    of = {b.key: b.of for b in v.result.answers}
    for a in student.answers:
        dep = deps[a.key]
        if dep.stage != "total":
            assert not dep.carriable and dep.reason and a.key not in again, a.key
            continue
        assert all(quantities.parse(of[u]).group for u in dep.upstream)
        assert (a.key in got) == bool(again[a.key].wrong)
        if load.name not in dep.held:
            assert _close(again[a.key], a.value), (a.key, again[a.key].value, a.value)


def test_a_static_problem_without_parts_carries_nothing_and_says_why():
    r = gradekit.solve(BANK["ch5-ex5-1"])
    deps = carry.dependencies(r)
    assert {d.reason for d in deps.values()} == {"it follows from given loads only (P)"}
    assert carry.carried(r, {a.key: 2 * a.value for a in r.answers}) == {}


def test_a_magnitude_keeps_the_exact_direction_and_blank_cells_count_as_not_given():
    """ch5-dyn-slider-crank asks |a_G2| only: a student's doubled |a_G2| doubles the rod's inertia
    force along the exact direction; NaN and text are not values."""
    p = BANK["ch5-dyn-slider-crank"]
    r = gradekit.solve(p)
    key = {a.key: a.value for a in r.answers}
    sub = {**key, "aG2": 2 * key["aG2"], "alpha2": math.nan, "a3": "n/a"}
    got = carry.carried(r, sub)
    assert [u.key for u in got["T"].used] == ["aG2"]
    # the rod's inertia force doubled along the same line, its couple exact: F12 gains once more the
    # solver's part of the rod's inertia force alone (the problem solved with the rod's I = 0)
    no_couple = dataclasses.replace(p, mass=tuple(
        dataclasses.replace(m, inertia=0.0) if m.body == "rod" else m for m in p.mass))
    alone = gradekit.solve(no_couple, r.values).cases[0].results
    part = alone["F[1,2]@inertia[2].x"][0], alone["F[1,2]@inertia[2].y"][0]
    total = r.cases[0].results["F[1,2].x"][0], r.cases[0].results["F[1,2].y"][0]
    assert got["F12"].value == pytest.approx(math.hypot(total[0] + part[0], total[1] + part[1]), rel=1e-9)
    assert "alpha2" not in {u.key for c in got.values() for u in c.used}


def test_feedback_names_the_students_wrong_values():
    used = (carry.Used("alpha2", 480.0, "rad/s**2", True), carry.Used("aG2", 2.1e5, "mm/s**2", True),
            carry.Used("aG2_dir", 312.0, "deg", False))
    c = carry.Carried("T", -900.0, "N*mm", used, Tolerance("relative", 0.02))
    assert c.describe() == "consistent with your alpha2 = 480 rad/s² and aG2 = 210000 mm/s²"
    assert c.accepts(-910.0) and not c.accepts(-930.0)
    assert c.accepts(-930.0, Tolerance("relative", 0.05))


@pytest.mark.parametrize("pid", DYNAMIC)
def test_a_class_batch_gives_each_student_what_their_variant_gives_alone(pid):
    """The plan of a solved batch (stem maps read for every variant at once) carries each row as
    the same variant solved on its own (a batch of one) does."""
    p = BANK[pid]
    vb = gradekit.sample_many(p, range(8))
    for i in range(len(vb)):
        v = vb.variant(i)
        student = _misread(p, v, p.inputs["omega"])
        submitted = {a.key: a.value for a in student.answers}
        in_batch = carry.plan(v.result).recompute(submitted)
        alone = gradekit.solve(p, v.values)
        assert v.result.batch is not alone.batch
        assert carry.dependencies(v.result) == carry.dependencies(alone)
        by_itself = carry.plan(alone).recompute(submitted)
        assert set(in_batch) == set(by_itself)
        for k, c in in_batch.items():
            assert _close(c, by_itself[k].value) and c.used == by_itself[k].used, k
