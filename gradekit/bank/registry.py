"""The bank: every problem file of a folder, loaded and validated together."""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable
from pathlib import Path

from gradekit.bank.model import Problem
from gradekit.bank.schema import load_problem
from gradekit.bank.yamlfile import is_regular
from gradekit.errors import ErrorList, GradekitError, ProblemError
from gradekit.resources import resource_dir

DEFAULT_BANK = resource_dir("problem_bank")
log = logging.getLogger("gradekit")


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
        if not is_regular(f):  # a FIFO would hang the read; a folder or device is no problem file
            log.warning("warning: %s: skipped, not a regular file", f)
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


_ID_LINE = re.compile(r"^id:[ \t]*[\"']?([^\"'\s#]+)", re.MULTILINE)


def load_problems(ids: Iterable[str], path: Path | str | None = None) -> dict[str, Problem]:
    """The bank's problems with these *ids*, parsing only their files: each file's top-level ``id:`` line
    is looked at first (an assignment names a few of the bank's problems). When an id is not found
    that way, or two files state one of them, the whole bank is loaded (`load_bank`), whose messages
    say what is wrong."""
    wanted = set(ids)
    folder = bank_dir(path)
    if not folder.is_dir():
        raise ProblemError(f"expected a folder of problem YAML files, got nothing at {folder}")
    files: dict[str, list[Path]] = {}
    for f in sorted(folder.glob("*.yaml")):
        if f.name.startswith("_"):
            continue
        if not is_regular(f):  # as load_bank: never read, and said
            log.warning("warning: %s: skipped, not a regular file", f)
            continue
        try:
            m = _ID_LINE.search(f.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError):
            continue
        if m and m.group(1) in wanted:
            files.setdefault(m.group(1), []).append(f)
    if set(files) != wanted or any(len(fs) > 1 for fs in files.values()):
        return load_bank(path)
    problems = {pid: load_problem(fs[0]) for pid, fs in files.items()}
    if any(p.id != pid for pid, p in problems.items()):  # an id line the scan misread
        return load_bank(path)
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
