"""`gradekit bank check`: draw many variants of each problem and check every one of them (above the bank:
it uses sampling and reporting, which the bank itself never imports).

The published variant reproduces every printed value (``published:``) at its printed precision.
For each variant: it assembles, solves, passes the virtual-work check, stays inside the problem's
conditioning bounds, its key grades itself 100 % and every answer moved just outside its
tolerance band grades 0. Prints per problem the rejection rate, answer ranges, worst transmission
angle and condition number, and how many distinct variants a class gets.

Both sides of every automatically graded answer (issue 25; `LEGEND` is printed with the table): the
honest false-reject bound the study measured (``ub`` of the bank's ``_tolerances.yaml``, written by
benchmarks/derive_tolerances.py) must be below 0.1 %; an answer 10 % off (a direction 5° off) and each
catalogued or generic mistake that moves the answer by more than that must lose its credit in at least
95 % of the variants drawn. A mistake that moves the answer less is reported as too small to grade.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from gradekit.bank.measured import measured_tolerances
from gradekit.bank.registry import load_bank
from gradekit.errors import GradekitError
from gradekit.grading.compare import generic_mistakes
from gradekit.mechanics.forces import VW_LIMIT
from gradekit.numbers import fmt
from gradekit.solving.answers import published_mismatches
from gradekit.solving.keys import KeyEntry, Tolerance, tolerance_columns, within
from gradekit.solving.mistakes import mistakes_many
from gradekit.solving.sampling import class_variants, derive_seed, sample_many, variant
from gradekit.solving.tolerances import (
    DISCRIMINATION_MIN,
    FALSE_REJECT_MAX,
    OFF_FAR,
    OFF_NEAR,
    accepted_off,
    band_text,
    is_direction,
    mistake_gradable,
    mistake_size,
)

LEGEND = (
    "    columns: answer | band the grader applies | honest: 95 % upper bound of the honest false-reject rate "
    "measured by benchmarks/derive_tolerances.py (goal < 0.1 %) | 5%/2°: share of variants where an answer 5 % "
    "off (a direction 2° off) still earns full credit | 10%/5°: the same 10 % (5°) off (goal ≤ 5 %) | "
    "mistake: the catalogued or generic mistake that most often still earns full credit, the share of variants "
    "and its median size (goal: ≤ 5 % of the variants where it moves the answer more than 10 % or 5°; where it "
    "moves it less it is no error a band must reject) | verdict"
)


def _self_grade_failures(key: str, tol: Tolerance, values: np.ndarray, scales: np.ndarray) -> list[str]:
    """Every variant's key grades itself and answers just outside its band are rejected (all variants
    at once). On the first 50, the tolerance resolved for each variant (its floor made absolute, as each
    student's key entry carries it) and compared as the grader compares a class (`tolerance_columns`,
    `within`) is checked to agree with the batched one."""
    bad = []
    band = tol.bands(values, scales)
    for i in np.flatnonzero(band <= 0):
        bad.append(f"variant {i}: {key}: zero-width tolerance band at {values[i]}")
    for i in np.flatnonzero(~tol.accepts_many(values, values, scales)):
        bad.append(f"variant {i}: {key}: the key does not grade itself")
    first = min(50, len(values))
    resolved = tolerance_columns([tol.resolve(float(s)) for s in scales[:first]])
    for sign in (1, -1):
        outside = values + sign * (1.001 * band + 1e-12 * np.abs(values))
        many = tol.accepts_many(outside, values, scales)
        for i in np.flatnonzero(many & (band > 0)):
            bad.append(f"variant {i}: {key}: {outside[i]} just outside the band is still accepted")
        for i in np.flatnonzero(within(outside[:first], values[:first], *resolved) != many[:first]):
            bad.append(f"variant {i}: {key}: the batched tolerance and the one resolved for the variant disagree")
    return bad


def _worst_condition(batch, sel: np.ndarray) -> float:
    """The largest condition number of rows *sel* of a solved batch (``batch.condition_number[sel].max()``),
    with an SVD of those rows only: a sampled batch also holds the candidates its constraints rejected."""
    worst = 0.0
    for case in batch.cases:
        c = case.solutions.conditioning
        worst = max(worst, float(c.take(sel).values.max()))
    return worst


def _band_check(problem, a, sel: np.ndarray, found: dict) -> tuple[float, int, int, int, int]:
    """How much wider than the band its draws were accepted with (the file's ``constraints.bands``)
    answer *a* is graded (its largest ratio; 0 when never wider); in how many of those variants the
    key is too near zero to grade at the grading band (``gradable``: a sign flip or a zero could be
    accepted, a grading defect); and in how many a declared mistake falls inside the grading band
    (``distinguish``: honest students win, the mistake is then not detected, as RESULTS reports); in
    how many the grading band reaches zero (a blank or zero answer would be accepted: a defect); and
    in how many an answer whose band the file states is graded at another band (one band, stated
    once: a stale ``_tolerances.yaml`` or an explicit ``tolerance:`` beside it)."""
    c = problem.constraints
    stated, graded = c.band(a)[sel], a.spec.tolerance.bands(a.value[sel], a.scale[sel])
    other = int((np.abs(graded - stated) > 1e-9 * np.maximum(stated, 1e-300)).sum()) if a.spec.key in c.bands else 0
    wider = graded > stated * (1 + 1e-9)
    if not wider.any():
        return 0.0, 0, 0, 0, other
    ungradable = (a.unit != "deg") & (np.abs(a.value[sel]) < c.gradable * graded)
    zero_ok = (a.unit != "deg") & (np.abs(a.value[sel]) <= graded)
    hidden = np.zeros_like(wider)
    for name, keys in c.distinguish:
        m = next((m for m in found.get(a.key, []) if m.name == name), None)
        if m is not None and any(a.key == k or a.key.startswith(k + "_") for k in keys):
            gap = np.abs(a.spec.tolerance.difference(m.value[sel], a.value[sel]))
            hidden |= m.changed[sel] & (gap < c.distinguish_factor * graded)
    return (float(np.max(graded / stated)), int((ungradable & wider).sum()), int((hidden & wider).sum()),
            int((zero_ok & wider).sum()), other)


class _Sides:
    """Both sides of one answer over the variants drawn (cases of one answer pooled)."""

    def __init__(self, key: str, unit: str, band: Tolerance, hand: bool, ub: float | None, measured: bool) -> None:
        self.key, self.unit, self.band, self.hand, self.ub = key, unit, band, hand, ub
        self.measured = measured  # the problem's folder holds a measured table (a file of its own may not yet)
        self.n = 0
        self.near = self.far = 0
        self.mistakes: dict[str, list] = {}  # name -> [variants where it applies, accepted, sizes]

    def add(self, a, sel: np.ndarray, found: dict) -> None:
        tol, vals, sc = a.spec.tolerance, a.value[sel], a.scale[sel]
        self.n += len(sel)
        self.near += int(accepted_off(tol, vals, sc, a.unit, OFF_NEAR).sum())
        self.far += int(accepted_off(tol, vals, sc, a.unit, OFF_FAR).sum())
        wrong = [(m.name, m.value[sel], m.changed[sel]) for m in found.get(a.key, [])]
        for mk in generic_mistakes(KeyEntry("", "", a.key, 1.0, a.unit, Tolerance())):
            if not any(w[0] == mk.name for w in wrong):
                live = vals != 0 if mk.name == "sign flipped" else np.ones(len(sel), bool)
                wrong.append((mk.name, vals * mk.value, live))
        for name, got, live in wrong:
            live = live & np.isfinite(got)
            if not live.any():
                continue
            ok = tol.accepts_many(got[live], vals[live], sc[live])
            size = mistake_size(tol, got[live], vals[live], a.unit)
            big = np.array([mistake_gradable(float(x), a.unit) for x in size], bool)
            rec = self.mistakes.setdefault(name, [0, 0, [], 0, 0])
            rec[0] += int(live.sum())
            rec[1] += int(ok.sum())
            rec[2].append(size)
            rec[3] += int(big.sum())  # the variants where the mistake is larger than what a band must reject
            rec[4] += int((ok & big).sum())

    def mistake_rows(self) -> list[tuple[str, float, float, float]]:
        """(name, share of variants accepted, median size, share accepted of the variants where it is larger
        than the 10 % / 5° a band must reject: the goal's; 0 when it is never that large)."""
        out = []
        for name, (live, acc, sizes, big, big_acc) in self.mistakes.items():
            med = float(np.median(np.concatenate(sizes)))
            out.append((name, acc / live, med, big_acc / big if big else 0.0))
        return sorted(out, key=lambda r: -r[1])

    def failures(self) -> list[str]:
        if self.hand:
            return []
        bad = []
        if self.ub is None:
            if self.measured:  # a measured bank's table without this answer: stale
                bad.append(f"{self.key}: honest false-reject rate not measured at its band "
                           "(run benchmarks/derive_tolerances.py)")
        elif self.ub >= 100 * FALSE_REJECT_MAX:
            bad.append(f"{self.key}: honest false-reject bound {self.ub:.3f} %, "
                       f"expected below {100 * FALSE_REJECT_MAX:g} %")
        if self.far > (1 - DISCRIMINATION_MIN) * self.n:
            bad.append(f"{self.key}: an answer 10 % (5°) off earns full credit in {self.far / self.n:.1%} of variants, "
                       f"expected at most {1 - DISCRIMINATION_MIN:.0%}")
        for name, _share, _med, big_share in self.mistake_rows():
            if big_share > 1 - DISCRIMINATION_MIN:
                bad.append(f"{self.key}: mistake {name!r} earns full credit in {big_share:.1%} of the variants where "
                           f"it moves the answer more than 10 % (5°), expected at most {1 - DISCRIMINATION_MIN:.0%}")
        return bad

    def row(self) -> str:
        band = "hand check" if self.hand else band_text(self.band)
        ub = "unmeasured" if self.ub is None else f"{self.ub:.3f} %"
        rows = self.mistake_rows()
        worst = next((r for r in rows if r[1] > 0), None)
        mis = "none passes" if worst is None else f"{worst[0]} {worst[1]:.0%} (size {worst[2]:.3g}" + (
            "°)" if is_direction(self.unit) else f" = {100 * worst[2]:.3g} %)")
        verdict = "hand" if self.hand else ("ok" if not self.failures() else "FAIL")
        return (f"    {self.key:<10} {band:<34} honest {ub:>9}  5%/2° {self.near / max(self.n, 1):6.1%}  "
                f"10%/5° {self.far / max(self.n, 1):6.1%}  mistake {mis:<44} {verdict}")


def check_problem(problem, n: int, class_size: int, echo: Callable[[str], None], legend: bool = True) -> bool:
    """Check *n* variants of one problem (drawn and solved in batches); print its summary (with the
    legend of the answers' columns unless *legend* is False); True when all pass."""
    failures: list[str] = []
    wide: dict[str, list] = {}  # answer -> [largest grading/draw band ratio, variants broken, hidden, zero, other]
    sides: dict[str, _Sides] = {}
    # the honest side as benchmarks/derive_tolerances.py measured it (a problem not in a measured table: unmeasured)
    measured = (measured_tolerances(Path(problem.path).parent).get(problem.id) or {}) if problem.path else {}
    randoms = any(p.random for p in problem.parameters.values())
    count = n if randoms else 1
    try:
        vb = (
            sample_many(problem, [derive_seed("bank-check", "", str(i), problem.id) for i in range(count)])
            if randoms
            else sample_many(problem, [None])
        )
    except GradekitError as exc:
        echo(f"{problem.id:<30} FAIL  {exc.format_message()}")
        return False
    for i in np.flatnonzero(~vb.ok):
        failures.append(f"variant {i}: {vb.reason(int(i))}")
    draws = int(vb.draws[vb.ok].sum()) if randoms else 1
    accepted = int(vb.ok.sum())
    worst_mu, worst_cond, worst_vw = 180.0, 0.0, 0.0
    ranges: dict[str, tuple[float, float]] = {}
    units: dict[str, str] = {}
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        worst_mu = min(worst_mu, float(batch.transmission_angle[sel].min()))
        worst_cond = max(worst_cond, _worst_condition(batch, sel))
        vw = batch.virtual_work_residual[sel]
        worst_vw = max(worst_vw, float(vw.max()))
        for i in np.flatnonzero(vw > VW_LIMIT):
            failures.append(f"variant {rows[i]}: virtual-work residual {vw[i]:.2e} > {VW_LIMIT}")
        cond_bad = batch.condition_above(problem.constraints.condition_max)[sel]
        failures.extend(f"variant {rows[i]}: condition number above the bound" for i in np.flatnonzero(cond_bad))
        raw = next(r[2] for r in vb.rows if r is not None and r[0] is batch)
        kept = np.isin(np.arange(batch.n), sel)
        found = mistakes_many(batch, raw, rows=kept)
        for a in batch.answer_list:
            if a.spec.key not in sides:
                row = measured.get(a.spec.key)
                ub = float(row["ub"]) if isinstance(row, dict) and "ub" in row else None
                sides[a.spec.key] = _Sides(a.spec.key, a.unit, a.spec.tolerance, a.spec.hand_check, ub, bool(measured))
            sides[a.spec.key].add(a, sel, found)
            units[a.key] = a.unit
            vals = a.value[sel]
            if not np.isfinite(vals).all():
                failures.append(f"{a.key} is not finite in {int((~np.isfinite(vals)).sum())} variants")
            lo, hi = ranges.get(a.key, (math.inf, -math.inf))
            ranges[a.key] = (min(lo, float(vals.min())), max(hi, float(vals.max())))
            failures.extend(_self_grade_failures(a.key, a.spec.tolerance, vals, a.scale[sel]))
            ratio, broken, hidden, zero, other = _band_check(problem, a, sel, found)
            w = wide.setdefault(a.key, [0.0, 0, 0, 0, 0])
            w[0], w[1], w[2], w[3], w[4] = max(w[0], ratio), w[1] + broken, w[2] + hidden, w[3] + zero, w[4] + other
    # Each band is stated once, in the problem file: grading at another band is a failure (a stale
    # _tolerances.yaml, or an explicit tolerance: beside the stated band). An answer with an explicit
    # tolerance: and no stated band may be graded wider than its draws were judged by (honest
    # students win, issue 16): reported below with what it costs, a failure only when it reaches
    # zero (a zero answer accepted).
    failures.extend(
        f"{key}: graded at a band wider than the band its draws were accepted with (constraints.bands), "
        f"reaching zero in {zero} variants (a zero answer would be accepted)"
        for key, (_ratio, _broken, _hidden, zero, _other) in wide.items()
        if zero
    )
    failures.extend(
        f"{key}: graded at a band other than the one the file states (constraints.bands) in {other} variants: "
        "state it once (no explicit tolerance: beside it) and re-run benchmarks/derive_tolerances.py"
        for key, (*_, other) in wide.items()
        if other
    )
    if problem.published:  # the published variant reproduces every printed value at its precision
        try:
            failures.extend(f"published: {m}" for m in published_mismatches(variant(problem).result))
        except GradekitError as exc:
            failures.append(f"published variant: {exc.format_message()}")
    for sd in sides.values():
        failures.extend(sd.failures())
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
    rejection = 1 - accepted / draws if draws else 1.0
    status = "ok" if not failures else "FAIL"
    echo(
        f"{problem.id:<30} {status:<4} variants {count:>5}  rejected {rejection:6.1%}  "
        f"worst μ {worst_mu:5.1f}°  worst cond {worst_cond:9.3g}  max vw {worst_vw:.1e}  "
        f"distinct {distinct}/{class_size if randoms else 1}"
    )
    for key, (lo, hi) in ranges.items():
        echo(f"    {key:<14} {fmt(lo, 4):>12} .. {fmt(hi, 4):<12} {units.get(key, '')}")
    if legend:
        echo(LEGEND)
    for sd in sides.values():
        echo(sd.row())
    for key, (ratio, broken, hidden, _zero, _other) in wide.items():
        if ratio:
            costs = [f"the key within {problem.constraints.gradable:g} grading bands of zero in {broken} variants "
                     "(a sign flip can be accepted)"] if broken else []
            costs += [f"a declared mistake inside the grading band in {hidden} variants"] if hidden else []
            echo(f"    ~ {key}: graded at up to {ratio:.3g}x the band its draws were accepted with"
                 + (": " + "; ".join(costs) if costs else ""))
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
    for i, pid in enumerate(ids):
        ok &= check_problem(problems[pid], n, class_size, echo, legend=i == 0)
    echo("bank check: " + ("all problems passed" if ok else "FAILED"))
    return ok
