"""The measured tolerance table of a bank folder (``_tolerances.yaml``, written by
benchmarks/derive_tolerances.py) and how it gives each answer its default tolerance.

Generated data: it sets how answers are graded, never what a student's numbers are (the sampler
reads the bands the problem file states)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from gradekit.bank.model import Problem
from gradekit.errors import ProblemError
from gradekit.keys import Tolerance

MEASURED = "_tolerances.yaml"
_MEASURED_CACHE: dict[Path, dict] = {}


def measured_tolerances(folder: Path) -> dict:
    """``{problem id: {answer key: row}}`` from the folder's ``_tolerances.yaml`` (written by
    benchmarks/derive_tolerances.py), or {} when there is none."""
    f = folder / MEASURED
    if f not in _MEASURED_CACHE:
        import yaml

        try:
            data = yaml.safe_load(f.read_text(encoding="utf-8")) if f.is_file() else {}
        except (OSError, yaml.YAMLError) as exc:
            raise ProblemError(f"expected the generated tolerance table, got {exc}", path=str(f)) from None
        _MEASURED_CACHE[f] = data if isinstance(data, dict) else {}
    return _MEASURED_CACHE[f]


def apply_measured(problem: Problem, table: dict) -> Problem:
    """Give every answer without an explicit ``tolerance:`` its measured default."""
    rows = table.get(problem.id) or {}
    if not rows:
        return problem
    answers = []
    for a in problem.answers:
        row = rows.get(a.key)
        if a.tolerance_explicit or not isinstance(row, dict):
            answers.append(a)
            continue
        if "deg" in row:
            tol = Tolerance("relative", 0.0, float(row["deg"]), a.tolerance.sigfigs, 0.0, a.tolerance.period or 360.0)
        else:
            tol = Tolerance(
                "relative", float(row["rel"]), 0.0, a.tolerance.sigfigs, float(row["floor"]), a.tolerance.period
            )
        answers.append(replace(a, tolerance=tol))
    return replace(problem, answers=tuple(answers))
