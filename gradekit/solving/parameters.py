"""Parameters phase: a variant's values completed (derived parameters) and rounded as printed.

The values a student sees are the values the solver uses: derived parameters (``expr``) are
evaluated from the drawn ones and rounded like every printed number (`round_display`).
"""

from __future__ import annotations

import math

import numpy as np

from gradekit.bank import expr
from gradekit.bank.model import Parameter, Problem, order
from gradekit.errors import ProblemError
from gradekit.mechanics.model import Refusals


def _overrides(values: dict) -> dict:
    """Values with case overrides given as expressions (``m4``, ``"2*phi"``) evaluated on the others."""
    if not any(isinstance(v, str) for v in values.values()):
        return values
    base = {k: v for k, v in values.items() if not isinstance(v, str)}
    out = dict(base)
    for k, v in values.items():
        if isinstance(v, str):
            scalar = all(np.ndim(x) == 0 for x in base.values())
            res = expr.evaluate(v, base) if scalar else expr.evaluate_many(v, base)
            out[k] = float(res) if scalar else np.asarray(res, float)
    return out


def fill(problem: Problem, values: dict[str, float]) -> dict[str, float]:
    """Complete *values* with the derived parameters (``expr``): rounded as printed where the
    parameter states how it is printed (``decimals``, ``sigfigs``, ``step``: the student is given
    that number), else kept at full precision."""
    out = dict(_overrides(values))
    for name in order(problem.parameters):
        p = problem.parameters[name]
        if p.expr and name not in values:
            try:
                v = float(expr.evaluate(p.expr, out))
            except expr.ExprError as exc:
                raise ProblemError(str(exc), path=problem.path, field=f"parameters.{name}.expr") from None
            out[name] = round_display(p, v)
    return out


def fill_many(problem: Problem, values: dict, n: int, bad: Refusals) -> dict[str, np.ndarray]:
    """`fill` for a batch: arrays of *n* values; a variant whose derived value is undefined is refused."""
    out = {k: np.broadcast_to(np.asarray(v, float), (n,)) for k, v in _overrides(values).items()}
    for name in order(problem.parameters):
        p = problem.parameters[name]
        if not p.expr or name in values:
            continue
        field = f"parameters.{name}.expr"
        try:
            rows = expr.evaluate_rows(p.expr, out)
        except expr.ExprError as exc:
            raise ProblemError(str(exc), path=problem.path, field=field) from None
        for undefined, message in rows.checks:  # a variant refused earlier keeps its first reason
            bad.add(undefined, lambda i, f=field, m=message: f"derived: {f}: {m(i)}")
        col = np.full(n, np.nan)
        derived = np.broadcast_to(np.asarray(rows.value, float), (n,))
        for i in np.flatnonzero(~bad.mask):
            try:
                col[i] = round_display(p, float(derived[i]))
            except (ValueError, OverflowError) as exc:  # a whole step of an infinite value
                bad.add(np.arange(n) == i, lambda _i, f=field, e=str(exc): f"derived: {f}: {e}")
        out[name] = col
    return out


def round_display(p: Parameter, v: float) -> float:
    """Round *v* the way parameter *p* is printed (its decimals, significant figures or step);
    unchanged when *p* states none."""
    if p.decimals is not None:
        return round(v, p.decimals)
    if p.sigfigs:
        return sig_round(v, p.sigfigs)
    if p.step:
        return round(round(v / p.step) * p.step, 10)
    return v  # no printed precision stated: full precision (the statement prints 6 significant figures)


def sig_round(v: float, sig: int) -> float:
    if v == 0 or not math.isfinite(v):
        return v
    return round(v, sig - 1 - int(math.floor(math.log10(abs(v)))))


def published_values(problem: Problem) -> dict[str, float]:
    """The fixed ('as published') values of every non-derived parameter."""
    return {n: p.value for n, p in problem.parameters.items() if not p.expr and p.value is not None}
