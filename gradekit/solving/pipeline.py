"""From a problem and parameter values (one variant, or a batch) to the solved answers.

The phases, each a module: parameters (`gradekit.solving.parameters`: derived values, rounding) →
assembly (`gradekit.solving.assembly`: problem + values → linkage and loads, SI) → the numeric core
(`gradekit.mechanics`: kinematics and forces, batched) → answers (`gradekit.solving.answers`: named
results, answer values and scales). The batched path (`solve_many`) is the only path: one
variant is a batch of one (`solve_problem`). Refused variants of a batch (cannot be assembled,
too ill-conditioned, a derived value undefined) are masked with their reasons, never raised; one
variant raises its reason as a `GeometryError` with the problem file and field.
"""

from __future__ import annotations

import numpy as np

from gradekit import units
from gradekit.bank.model import Problem
from gradekit.errors import ProblemError
from gradekit.mechanics import forces
from gradekit.mechanics.model import Refusals
from gradekit.solving.answers import (  # noqa: F401 (the pipeline's records, re-exported)
    AnswerBatch,
    Answers,
    CaseBatch,
    CaseResult,
    Result,
    ResultBatch,
    Results,
    SolvedAnswer,
    flat_results,
)
from gradekit.solving.assembly import SI, Context, build_analysis, build_linkage, length_formatter  # noqa: F401
from gradekit.solving.parameters import fill, fill_many, published_values, round_display, sig_round  # noqa: F401


def _solve_case(problem: Problem, values: dict, n: int, name: str | None, bad: Refusals) -> CaseBatch:
    link = build_linkage(problem, values, n=n)
    link.refused.merge(bad, first=True)  # variants refused before the build stay refused, with their reason
    speed = np.broadcast_to(np.asarray(link.bodies[link.input_body].angle.d, float), (n,))
    virtual = None if speed.all() else build_linkage(problem, values, True, n)
    sols = forces.solve_many(link, build_analysis(problem, values, n), virtual)
    return CaseBatch(name, values, sols, flat_results(problem, sols, values))


def solve_many(problem: Problem, values: dict, n: int | None = None) -> ResultBatch:
    """Solve every case of *problem* for a batch of variants.

    Args:
        problem: the problem.
        values: each non-derived parameter's values (arrays of one entry per variant, or floats
            shared by all), in the parameter's unit, as the students see them.
        n: the batch size (from the arrays when omitted).
    """
    if n is None:
        n = max((np.size(v) for v in values.values()), default=1)
    bad = Refusals(n)
    full = fill_many(problem, values, n, bad)
    if problem.cases:
        cases = [
            _solve_case(problem, fill_many(problem, {**values, **over}, n, bad), n, name, bad)
            for name, over in problem.cases.items()
        ]
    else:
        cases = [_solve_case(problem, full, n, None, bad)]
    refused = bad.copy()
    for c in cases:
        refused.merge(c.solutions.refused)
    answers = []
    for spec in problem.answers:
        for case in cases:
            if spec.case is not None and spec.case != case.name:
                continue
            key = spec.key if (spec.case is not None or case.name is None) else f"{spec.key}_{case.name}"
            if spec.of not in case.results:
                raise ProblemError(
                    f"expected a result this mechanism reports (e.g. "
                    f"{', '.join(sorted(k for k in case.results if '.' not in k)[:8])}), "
                    f"got {spec.of!r}",
                    path=problem.path,
                    field=f"answers.{spec.key}.of",
                )
            si_value, si_unit = case.results[spec.of]
            try:
                value = (
                    units.convert(si_value, si_unit, spec.unit) if si_unit != "deg" or spec.unit != "deg" else si_value
                )
            except Exception:
                raise ProblemError(
                    f"expected a unit of the same kind as {si_unit}, got {spec.unit!r}",
                    path=problem.path,
                    field=f"answers.{spec.key}.unit",
                ) from None
            answers.append(AnswerBatch(key, np.asarray(value, float), spec.unit, spec, case.name))
    # Floors are fractions of the variant's scale: its largest answer of the same dimension,
    # compared in SI (an answer in kN beside one in N), expressed in each answer's own unit.
    by_dim: dict[str, list[AnswerBatch]] = {}
    for a in answers:
        by_dim.setdefault(units.si_unit(a.unit), []).append(a)
    for dim, group in by_dim.items():
        if len({a.unit for a in group}) == 1:
            top = np.maximum.reduce([np.abs(a.value) for a in group])
            for a in group:
                a.scale = top
        else:
            top = np.maximum.reduce([np.abs(units.to_si(a.value, a.unit)) for a in group])
            for a in group:
                a.scale = top * units.factor(dim, a.unit)
    return ResultBatch(problem, full, cases, answers, refused)


def solve_problem(problem: Problem, values: dict[str, float]) -> Result:
    """Solve every case of *problem* for one student's *values* and express the answers.

    Raises:
        GeometryError: the variant cannot be assembled or is too near a singular position.
        ProblemError: a derived value is undefined for these values.
    """
    batch = solve_many(problem, values, 1)
    if batch.refused.mask[0]:
        reason = batch.reason(0)
        if reason.startswith("derived: "):
            fld, _, msg = reason[len("derived: ") :].partition(": ")
            raise ProblemError(msg, path=problem.path, field=fld)
    return batch.take(0)


__all__ = [
    "Result",
    "ResultBatch",
    "build_linkage",
    "fill",
    "published_values",
    "solve_many",
    "solve_problem",
]
