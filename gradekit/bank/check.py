"""`gradekit bank check`: draw many variants of each problem and check every one of them.

For each variant: it assembles, solves, passes the virtual-work check, stays inside the problem's
conditioning bounds, its key grades itself 100 % and every answer moved just outside its
tolerance band grades 0. Prints per problem the rejection rate, answer ranges, worst transmission
angle and condition number, and how many distinct variants a class gets.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

from gradekit.bank.registry import load_bank
from gradekit.errors import GradekitError
from gradekit.mechanics.forces import VW_LIMIT
from gradekit.report import fmt
from gradekit.sampling import class_variants, derive_seed, variant


def _self_grade_failures(result) -> list[str]:
    bad = []
    for a in result.answers:
        tol = a.tolerance
        if not tol.accepts(a.value, a.value):
            bad.append(f"{a.key}: the key does not grade itself")
        band = tol.band(a.value)
        if band <= 0:
            bad.append(f"{a.key}: zero-width tolerance band at {a.value}")
            continue
        for outside in (a.value + 1.001 * band + 1e-12 * abs(a.value), a.value - 1.001 * band - 1e-12 * abs(a.value)):
            if tol.accepts(outside, a.value):
                bad.append(f"{a.key}: {outside} just outside the band is still accepted")
    return bad


def check_problem(problem, n: int, class_size: int, echo: Callable[[str], None]) -> bool:
    """Check *n* variants of one problem; print its summary line(s); True when all pass."""
    failures: list[str] = []
    units: dict[str, str] = {}
    draws = 0
    ranges: dict[str, list[float]] = {}
    worst_mu, worst_cond, worst_vw = 180.0, 0.0, 0.0
    randoms = any(p.random for p in problem.parameters.values())
    count = n if randoms else 1
    for i in range(count):
        try:
            v = (
                variant(problem, seed=derive_seed("bank-check", "", str(i), problem.id))
                if randoms
                else variant(problem)
            )
        except GradekitError as exc:
            failures.append(f"variant {i}: {exc.format_message()}")
            continue
        draws += max(v.draws, 1)
        r = v.result
        worst_mu = min(worst_mu, r.transmission_angle)
        worst_cond = max(worst_cond, r.condition_number)
        worst_vw = max(worst_vw, r.virtual_work_residual)
        if r.virtual_work_residual > VW_LIMIT:
            failures.append(f"variant {i}: virtual-work residual {r.virtual_work_residual:.2e} > {VW_LIMIT}")
        if r.condition_number > problem.constraints.condition_max:
            failures.append(f"variant {i}: condition number {r.condition_number:.3g} above the bound")
        for a in r.answers:
            units[a.key] = a.unit
            if not math.isfinite(a.value):
                failures.append(f"variant {i}: {a.key} is not finite")
            ranges.setdefault(a.key, []).append(a.value)
        failures.extend(f"variant {i}: {m}" for m in _self_grade_failures(r))
    distinct = 1
    if randoms:
        try:
            cls = class_variants(problem, "MEG373", "bank-check", [f"student-{s:04d}" for s in range(class_size)])
            distinct = len({tuple(sorted(v.values.items())) for v in cls.values()})
        except GradekitError as exc:
            failures.append(f"class of {class_size}: {exc.format_message()}")
            distinct = 0
        if distinct < class_size:
            failures.append(f"only {distinct} distinct variants for a class of {class_size}")
    rejection = 1 - count / draws if draws else 1.0
    status = "ok" if not failures else "FAIL"
    echo(
        f"{problem.id:<30} {status:<4} variants {count:>5}  rejected {rejection:6.1%}  "
        f"worst μ {worst_mu:5.1f}°  worst cond {worst_cond:9.3g}  max vw {worst_vw:.1e}  "
        f"distinct {distinct}/{class_size if randoms else 1}"
    )
    for key, vals in ranges.items():
        unit = units.get(key, "")
        echo(f"    {key:<14} {fmt(min(vals), 4):>12} .. {fmt(max(vals), 4):<12} {unit}")
    for f in failures[:10]:
        echo(f"    ! {f}")
    if len(failures) > 10:
        echo(f"    ! … and {len(failures) - 10} more failures")
    return not failures


def check_bank(ids: Iterable[str], n: int, class_size: int, bank=None, echo: Callable[[str], None] = print) -> bool:
    """Check the listed problems (all when none); True when every one passes."""
    problems = load_bank(bank)
    ids = list(ids) or list(problems)
    unknown = [i for i in ids if i not in problems]
    if unknown:
        raise GradekitError(f"expected bank ids ({', '.join(sorted(problems))}), got {', '.join(unknown)}")
    ok = True
    for pid in ids:
        ok &= check_problem(problems[pid], n, class_size, echo)
    echo("bank check: " + ("all problems passed" if ok else "FAILED"))
    return ok
