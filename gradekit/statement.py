"""Render a problem statement (jinja2) with one variant's values, formatted as printed."""

from __future__ import annotations

import jinja2

from gradekit import units
from gradekit.bank.schema import Problem
from gradekit.errors import ProblemError
from gradekit.report import fmt

_ENV = jinja2.Environment(undefined=jinja2.StrictUndefined, autoescape=False, keep_trailing_newline=False)


class Shown(str):
    """A parameter as printed (``30 mm``), with ``.value`` and ``.unit`` for templates."""

    value: float
    unit: str


def shown(problem: Problem, name: str, value: float) -> Shown:
    par = problem.parameters[name]
    text = units.with_unit(fmt(value, 6), par.unit)
    s = Shown(text)
    s.value, s.unit = value, par.unit
    return s


def render_statement(problem: Problem, values: dict[str, float]) -> str:
    """The statement with each parameter name replaced by its value and unit."""
    ctx = {n: shown(problem, n, v) for n, v in values.items() if n in problem.parameters}
    try:
        return _ENV.from_string(problem.statement).render(**ctx).strip()
    except jinja2.TemplateError as exc:
        raise ProblemError(
            f"expected a statement using the problem's parameters, got {exc}", path=problem.path, field="statement"
        ) from None
