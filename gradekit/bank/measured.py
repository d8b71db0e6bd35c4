"""The grading band of every answer: stated once in the problem file, written out with its measurement.

A problem states each answer's band in ``constraints.bands`` (the band the sampler judges its draws
by: ``gradable``, ``distinguish``), or gives the answer an explicit ``tolerance:``. The bank folder's
``_tolerances.yaml`` (written by benchmarks/derive_tolerances.py) copies each stated band beside its
measured honest false-reject bound and mistake detection, and holds the per-kind defaults
(`gradekit.solving.tolerances`) for answers that state none. Grading applies the table's row, which is the
stated band unless the table is stale (`gradekit bank check` fails then); the sampler reads the
file alone, so re-deriving the table never changes a student's numbers.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from gradekit.bank.model import Problem
from gradekit.bank.yamlfile import safe_data
from gradekit.errors import ProblemError
from gradekit.solving.keys import Tolerance
from gradekit.solving.tolerances import from_row

MEASURED = "_tolerances.yaml"
_MEASURED_CACHE: dict[Path, dict] = {}


def measured_tolerances(folder: Path) -> dict:
    """``{problem id: {answer key: row}}`` from the folder's ``_tolerances.yaml`` (written by
    benchmarks/derive_tolerances.py), or {} when there is none."""
    f = folder / MEASURED
    if f not in _MEASURED_CACHE:
        try:
            text = f.read_text(encoding="utf-8") if f.is_file() else "{}"
        except OSError as exc:
            raise ProblemError(f"expected the generated tolerance table, got {exc}", path=str(f)) from None
        data = safe_data(text, f, "the generated tolerance table")
        _MEASURED_CACHE[f] = data if isinstance(data, dict) else {}
    return _MEASURED_CACHE[f]


def _with_band(tol: Tolerance, band: Tolerance) -> Tolerance:
    """*band*'s widths with *tol*'s mode and significant figures (angles keep their period)."""
    period = (tol.period or 360.0) if band.period else tol.period
    return replace(band, mode=tol.mode, sigfigs=tol.sigfigs, period=period)


def apply_measured(problem: Problem, table: dict) -> Problem:
    """Give every answer without an explicit ``tolerance:`` its band: the table's row (the band the
    file states, with its measurement), else the file's ``constraints.bands``, else it keeps the
    per-kind default."""
    rows = table.get(problem.id) or {}
    answers = []
    for a in problem.answers:
        row = rows.get(a.key)
        if a.tolerance_explicit:
            answers.append(a)
        elif isinstance(row, dict):
            answers.append(replace(a, tolerance=_with_band(a.tolerance, from_row(row))))
        elif a.key in problem.constraints.bands:
            answers.append(replace(a, tolerance=_with_band(a.tolerance, problem.constraints.bands[a.key])))
        else:
            answers.append(a)
    return replace(problem, answers=tuple(answers))
