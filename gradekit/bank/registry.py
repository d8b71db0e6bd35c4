"""The bank: every problem file of a folder, loaded and validated together."""

from __future__ import annotations

from pathlib import Path

from gradekit.bank.model import Problem
from gradekit.bank.schema import load_problem
from gradekit.errors import ErrorList, GradekitError, ProblemError
from gradekit.resources import resource_dir

DEFAULT_BANK = resource_dir("problem_bank")


def bank_dir(path: Path | str | None = None) -> Path:
    """The bank folder: *path*, else ``problem_bank`` of this checkout or the current folder."""
    if path:
        return Path(path)
    if DEFAULT_BANK.is_dir():
        return DEFAULT_BANK
    return Path.cwd() / "problem_bank"


def load_bank(path: Path | str | None = None) -> dict[str, Problem]:
    """Load every ``*.yaml`` problem; report all errors of all files together (ErrorList)."""
    folder = bank_dir(path)
    if not folder.is_dir():
        raise ProblemError(f"expected a folder of problem YAML files, got nothing at {folder}")
    problems: dict[str, Problem] = {}
    errors: list[GradekitError] = []
    for f in sorted(folder.glob("*.yaml")):
        if f.name.startswith("_"):  # generated data (e.g. _tolerances.yaml), not a problem
            continue
        try:
            p = load_problem(f)
        except ErrorList as exc:
            errors.extend(exc.errors)
            continue
        except GradekitError as exc:
            errors.append(exc)
            continue
        if p.id in problems:
            errors.append(
                ProblemError(
                    f"expected a unique id, got {p.id!r} (also in {problems[p.id].path})",
                    path=str(f),
                    line=p.lines.get("id"),
                    field="id",
                )
            )
            continue
        problems[p.id] = p
    if errors:
        raise ErrorList(errors)
    return problems


def resolve(spec: str, bank: Path | str | None = None) -> Problem:
    """A problem by bank id or by path to a YAML file."""
    path = Path(spec)
    if spec.endswith((".yaml", ".yml")) or path.is_file():
        return load_problem(path)
    problems = load_bank(bank)
    if spec not in problems:
        raise ProblemError(f"expected a bank id ({', '.join(sorted(problems))}) or a YAML path, got {spec!r}")
    return problems[spec]
