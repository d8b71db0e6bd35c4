"""The catalogued mistakes that need a re-solve, evaluated for one variant.

Static answer to a dynamic problem, the inertia torque left out, gravity left out (each solved
again with that mistake), x and y swapped and the magnitude given for a component (read off the
same solution). Sign flips and unit slips need no re-solve (`gradekit.grading.compare`).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from gradekit import units
from gradekit.bank.schema import Problem
from gradekit.errors import GradekitError
from gradekit.keys import Mistake

if TYPE_CHECKING:  # sampling imports this module
    from gradekit.sampling import Variant


def catalogued_mistakes(v: Variant) -> dict[str, list[Mistake]]:
    """Re-solve the variant with each catalogued mistake; map answer key -> mistakes that change it.

    Mistakes that need a re-solve: the inertia torque left out, gravity left out, a static answer
    to a dynamic problem, x and y swapped, magnitude given for a component. (Sign flips and unit
    slips need no re-solve; the grader adds them.)
    """
    from gradekit.pipeline import solve_problem

    p = v.problem
    out: dict[str, list[Mistake]] = {}
    variants: list[tuple[str, str, Problem]] = []
    if p.analysis == "dynamic":
        variants.append(
            (
                "static-answer",
                "a static answer to a dynamic problem (inertia left out)",
                dataclasses.replace(p, analysis="static"),
            )
        )
        if any(m.inertia not in (0, 0.0) for m in p.mass):
            no_i = tuple(dataclasses.replace(m, inertia=0.0) for m in p.mass)
            variants.append(("no-inertia-torque", "the inertia torque I·α left out", dataclasses.replace(p, mass=no_i)))
    if p.gravity is not None:
        variants.append(("no-gravity", "gravity (the weights) left out", dataclasses.replace(p, gravity=None)))
    for name, text, mp in variants:
        try:
            res = solve_problem(mp, v.values)
        except GradekitError:
            continue
        for a, b in zip(v.result.answers, res.answers, strict=True):
            if abs(b.value - a.value) > 1e-6 * max(abs(a.value), 1e-12):
                out.setdefault(a.key, []).append(Mistake(name, text, float(b.value)))
    for a in v.result.answers:
        comp = _swap_and_component(v, a)
        out.setdefault(a.key, []).extend(m for m in comp if abs(m.value - a.value) > 1e-9 * max(abs(a.value), 1))
    return out


def _swap_and_component(v: Variant, a) -> list[Mistake]:
    """x/y swapped and magnitude-for-component, read off the same solution's flat results."""
    if not a.of.endswith((".x", ".y")):
        return []
    case = next(c for c in v.result.cases if c.name == a.case)
    stem, comp = a.of.rsplit(".", 1)
    other = case.results.get(f"{stem}.{'y' if comp == 'x' else 'x'}")
    mag = case.results.get(f"{stem}.mag")
    out = []
    if other:
        out.append(Mistake("x-y-swapped", "the x and y components swapped", units.convert(other[0], other[1], a.unit)))
    if mag:
        out.append(
            Mistake(
                "magnitude-for-component", "the magnitude given for a component", units.convert(mag[0], mag[1], a.unit)
            )
        )
    return out


