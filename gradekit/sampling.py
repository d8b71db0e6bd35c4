"""Deterministic per-student values: seed derivation, rounding as printed, rejection sampling.

The seed is SHA-256 of (course, assignment salt, student id, problem id), fed to
`numpy.random.default_rng`; never Python's salted `hash()`, never global RNG state. Values are
rounded to the precision printed on the sheet, so the solver uses exactly what the student sees.
A draw is accepted only when the mechanism assembles, passes the virtual-work check and every
constraint of the problem; after ``max_draws`` rejections the error names the constraint that
rejected the most.
"""

from __future__ import annotations

import hashlib
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.schema import Parameter, Problem
from gradekit.errors import GeometryError, GradekitError, ProblemError, SamplingError
from gradekit.mechanics.forces import VW_LIMIT
from gradekit.pipeline import Result, fill, published_values, round_display, sig_round, solve_problem

MAX_DRAWS = 400


def derive_seed(course: str, salt: str, student: str, problem_id: str, redraw: int = 0) -> int:
    """A 64-bit seed from SHA-256 of the four identifiers (and a re-draw counter)."""
    text = "\x1f".join([course, salt, student, problem_id] + ([str(redraw)] if redraw else []))
    return int.from_bytes(hashlib.sha256(text.encode("utf-8")).digest()[:8], "big")


def draw(p: Parameter, rng: np.random.Generator) -> float:
    """One value of a random parameter, rounded as printed."""
    if p.choices:
        return float(p.choices[int(rng.integers(len(p.choices)))])
    assert p.low is not None and p.high is not None
    if p.step:
        n = int(math.floor((p.high - p.low) / p.step + 1e-9))
        return round(p.low + p.step * int(rng.integers(n + 1)), 10)
    return sig_round(float(rng.uniform(p.low, p.high)), p.sigfigs or 3)


@dataclass
class Variant:
    """One student's values of a problem and their solution."""

    problem: Problem
    values: dict[str, float]
    seed: int | None
    draws: int
    result: Result
    redraw: int = 0


def check(problem: Problem, values: dict[str, float]) -> tuple[str | None, Result | None]:
    """Solve *values* and test every constraint; return (rejecting constraint or None, result)."""
    c = problem.constraints
    try:
        full = fill(problem, values)
    except ProblemError as exc:  # a derived value undefined for this draw (e.g. sqrt of a negative)
        return f"derived: {exc.field}", None
    for text, message in c.require:
        try:
            if not expr.evaluate(text, full):
                return f"require: {message or text}", None
        except expr.ExprError:
            return f"require: {message or text}", None
    if problem.kind in ("fourbar", "fourbar_quick_return") and c.grashof:
        reason = _grashof(problem, full)
        if reason:
            return reason, None
    try:
        result = solve_problem(problem, values)
    except GeometryError as exc:
        return ("assembles" if "assembled" in exc.detail else "conditioning"), None
    except GradekitError:
        raise
    if result.virtual_work_residual > VW_LIMIT:
        return "virtual_work", result
    if result.condition_number > c.condition_max:
        return "condition_max", result
    if result.transmission_angle < c.transmission_min:
        return "transmission_min", result
    if c.dead_centre_min and problem.kind == "slider_crank":
        for case in result.cases:
            link = case.solution.linkage
            crank = link.points["A"].pos() - link.points["O2"].pos()
            rod = link.points["B"].pos() - link.points["A"].pos()
            ang = math.degrees(abs(math.atan2(crank[0] * rod[1] - crank[1] * rod[0], crank @ rod)))
            if min(ang, 180 - ang) < c.dead_centre_min:
                return "dead_centre_min", result
    if c.gradable:
        for a in result.answers:
            if a.unit != "deg" and abs(a.value) < c.gradable * a.tolerance.band(a.value):
                return "gradable", result
    if c.distinguish:
        from gradekit.mistakes import catalogued_mistakes

        found = catalogued_mistakes(Variant(problem, values, None, 0, result))
        answers = {a.key: a for a in result.answers}
        for name, keys in c.distinguish:
            for k in keys:
                for a in (x for key, x in answers.items() if key == k or key.startswith(k + "_")):
                    m = next((m for m in found.get(a.key, []) if m.name == name), None)
                    gap = abs(a.tolerance.difference(m.value, a.value)) if m else 0.0
                    if gap < c.distinguish_factor * a.tolerance.band(a.value):
                        return f"distinguish: {name} on {k}", result
    if c.answer_min_fraction:
        by_unit: dict[str, list[float]] = {}
        for a in result.answers:
            if a.unit != "deg":
                by_unit.setdefault(units.si_unit(a.unit), []).append(abs(a.value))
        for vals in by_unit.values():
            if min(vals) < c.answer_min_fraction * max(vals):
                return "answer_min_fraction", result
    return None, result


def _grashof(problem: Problem, full: dict[str, float]) -> str | None:
    from gradekit.pipeline import Context

    ctx = Context(problem, full)
    lens = {k: ctx.si(problem.geometry[k], "length", k) for k in ("crank", "coupler", "rocker", "frame")}
    s, l_ = min(lens.values()), max(lens.values())
    pq = sum(lens.values()) - s - l_
    want = problem.constraints.grashof
    grashof = s + l_ <= pq
    if want == "non-grashof":
        return None if not grashof else "grashof"
    if not grashof:
        return "grashof"
    if want == "crank-rocker" and s != lens["crank"]:
        return "grashof"
    if want == "double-crank" and s != lens["frame"]:
        return "grashof"
    return None


def variant(
    problem: Problem,
    *,
    course: str = "",
    salt: str = "",
    student: str | None = None,
    seed: int | None = None,
    redraw: int = 0,
    max_draws: int = MAX_DRAWS,
) -> Variant:
    """The variant of *problem* for *student* (or *seed*); the published one when both are None.

    Raises:
        SamplingError: no acceptable draw in *max_draws*; names the constraint that rejected most.
    """
    base = published_values(problem)
    if student is None and seed is None:
        reason, result = check(problem, base)
        if result is None:
            reason, result = None, solve_problem(problem, base)  # raises the geometry error itself
        return Variant(problem, base, None, 0, result)
    if seed is None:
        seed = derive_seed(course, salt, student or "", problem.id, redraw)
    rng = np.random.default_rng(seed)
    randoms = [p for p in problem.parameters.values() if p.random]
    if not randoms:
        return Variant(problem, base, seed, 0, solve_problem(problem, base))
    rejected: Counter[str] = Counter()
    for n in range(1, max_draws + 1):
        values = dict(base)
        for p in randoms:
            values[p.name] = round_display(p, draw(p, rng)) if not p.choices else draw(p, rng)
        reason, result = check(problem, values)
        if reason is None and result is not None:
            return Variant(problem, values, seed, n, result)
        rejected[reason or "unknown"] += 1
    worst, count = rejected.most_common(1)[0]
    raise SamplingError(
        f"expected an acceptable variant within {max_draws} draws, got none: "
        f"constraint {worst!r} rejected {count} of them ({dict(rejected)})",
        path=problem.path,
        field="constraints",
    )


def class_variants(
    problem: Problem,
    course: str,
    salt: str,
    students: list[str],
    redraws: dict[str, int] | None = None,
    frozen: bool = False,
    limit: int = 50,
) -> dict[str, Variant]:
    """Every student's variant, no two alike.

    A student starts at re-draw counter ``redraws[s]`` (0 by default: an instructor's explicit
    re-draw of one student changes only that student's seed). A student whose values repeat an
    earlier student's (in roster order) is re-drawn with the next counter, unless *frozen* (the
    counters come from a manifest and are reproduced exactly).
    """
    out: dict[str, Variant] = {}
    seen: set[tuple] = set()
    randoms = any(p.random for p in problem.parameters.values())
    for s in students:
        r = (redraws or {}).get(s, 0)
        v = variant(problem, course=course, salt=salt, student=s, redraw=r)
        key = tuple(sorted(v.values.items()))
        while randoms and key in seen and r < limit and not frozen:
            r += 1
            v = variant(problem, course=course, salt=salt, student=s, redraw=r)
            key = tuple(sorted(v.values.items()))
        v.redraw = r
        seen.add(key)
        out[s] = v
    return out
