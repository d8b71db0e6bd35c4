"""Deterministic per-student values: seed derivation, rounding as printed, batched rejection sampling.

The seed is SHA-256 of (course, assignment salt, student id, problem id), fed to
`numpy.random.default_rng`; never Python's salted `hash()`, never global RNG state. Values are
rounded to the precision printed on the sheet, so the solver uses exactly what the student sees.
A draw is accepted only when the mechanism assembles, passes the virtual-work check and every
constraint of the problem; after ``max_draws`` rejections the error names the constraint that
rejected the most. Sampling is batched: every pending variant's next draws (from its own
generator, so each variant's sequence is the one a one-at-a-time loop would draw, and its first
acceptable draw the one it keeps) are checked in one solve per round; when few variants are
pending, each draws several candidates ahead, so a class costs a few solves however often its
constraints reject.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.model import Parameter, Problem
from gradekit.errors import GradekitError, SamplingError
from gradekit.mechanics.forces import VW_LIMIT
from gradekit.mechanics.mechanisms import KINDS
from gradekit.mechanics.model import GROUND, Prismatic
from gradekit.solving.assembly import Context
from gradekit.solving.mistakes import mistakes_many
from gradekit.solving.parameters import published_values, round_display, sig_round
from gradekit.solving.pipeline import Result, ResultBatch, solve_many
from gradekit.solving.tolerances import ARM_MIN

MAX_DRAWS = 400
ROUND_ROWS = 1024  # candidate rows per batched solve when few seeds are pending (fewer pay its fixed cost for little)
TABLE_MAX = 1 << 16  # a stepped parameter with up to this many values has them rounded once, in a table

def derive_seed(course: str, salt: str, student: str, problem_id: str, redraw: int = 0) -> int:
    """A 64-bit seed from SHA-256 of the four identifiers (and a re-draw counter)."""
    text = "\x1f".join([course, salt, student, problem_id] + ([str(redraw)] if redraw else []))
    return int.from_bytes(hashlib.sha256(text.encode("utf-8")).digest()[:8], "big")


def draw(p: Parameter, rng: np.random.Generator) -> float:
    """One value of a random parameter, rounded as printed."""
    if p.choices:
        return float(p.choices[int(rng.integers(len(p.choices)))])
    assert p.low is not None and p.high is not None
    if p.step:
        return round(p.low + p.step * int(rng.integers(_steps(p) + 1)), 10)
    return sig_round(float(rng.uniform(p.low, p.high)), p.sigfigs or 3)


class _Drawer:
    """Many successive draws of a problem's random parameters from each generator, in one call per
    generator: row ``r`` of a generator's block is exactly what its ``r``-th round of `draw` (then
    `round_display`, as `sample_many` rounds) gives, and the generator consumes the same bits.

    Why it is the same: a stepped or listed parameter draws ``rng.integers(n + 1)``, and numpy's
    ``rng.integers(0, highs)`` with an array of highs draws each element with the same bounded
    generator (Lemire's, over the same 32-bit stream) as one scalar call per element; a continuous
    parameter draws ``rng.uniform(low, high)``, which is ``low + (high - low) * rng.random()``.
    Problems that mix the two (the 32-bit stream keeps half a word between integer calls that a
    uniform draw skips) draw one value at a time, as `draw` does. tests/test_sampling_blocks.py
    checks it against `draw` bit for bit.
    """

    def __init__(self, randoms: list[Parameter]):
        self.randoms = randoms
        if all(p.choices or p.step for p in randoms):
            self.kind = "integers"
            self.highs = np.array([len(p.choices) if p.choices else _steps(p) + 1 for p in randoms], np.int64)
            self.tables = [_table(p) for p in randoms]
            self.tiled = self.highs  # the highs repeated for as many draws as a generator has made at once
        elif not any(p.choices or p.step for p in randoms):
            self.kind = "uniform"
            self.lows = np.array([float(p.low) for p in randoms])
            self.spans = np.array([float(p.high) - float(p.low) for p in randoms])
        else:
            self.kind = "mixed"

    def rows(self, rngs: list[np.random.Generator], counts: np.ndarray) -> np.ndarray:
        """``counts[g]`` successive draws from ``rngs[g]``, every generator's after the previous one's,
        as an array (draw, parameter) of the values `sample_many` uses."""
        k = len(self.randoms)
        if self.kind == "mixed":
            return np.array(
                [
                    [draw(p, rng) if p.choices else round_display(p, draw(p, rng)) for p in self.randoms]
                    for rng, c in zip(rngs, counts, strict=True)
                    for _ in range(c)
                ],
                float,
            ).reshape(-1, k)
        if self.kind == "uniform":
            u = np.concatenate([rng.random(c * k) for rng, c in zip(rngs, counts, strict=True)]).reshape(-1, k)
            raw = self.lows + self.spans * u
            out = np.empty(raw.shape)
            for j, p in enumerate(self.randoms):
                out[:, j] = [round_display(p, sig_round(float(x), p.sigfigs or 3)) for x in raw[:, j]]
            return out
        if len(self.tiled) < counts.max() * k:
            self.tiled = np.tile(self.highs, int(counts.max()))
        tiled = self.tiled
        idx = np.concatenate([rng.integers(0, tiled[: c * k]) for rng, c in zip(rngs, counts, strict=True)])
        idx = idx.reshape(-1, k)
        out = np.empty(idx.shape)
        for j, (p, table) in enumerate(zip(self.randoms, self.tables, strict=True)):
            if table is not None:
                out[:, j] = table[idx[:, j]]
            else:  # a very fine step: round only the values drawn
                uniq, back = np.unique(idx[:, j], return_inverse=True)
                out[:, j] = np.array([_stepped(p, int(i)) for i in uniq], float)[back]
        return out


def _steps(p: Parameter) -> int:
    """The largest step index of a stepped parameter (its values are ``low + step * 0..n``)."""
    assert p.low is not None and p.high is not None and p.step
    return int(math.floor((p.high - p.low) / p.step + 1e-9))


def _stepped(p: Parameter, i: int) -> float:
    """Value *i* of a stepped parameter, rounded as `draw` and then `round_display` round it."""
    assert p.low is not None and p.step
    return round_display(p, round(p.low + p.step * i, 10))


def _table(p: Parameter) -> np.ndarray | None:
    """Every value a listed or stepped parameter can take, by the integer drawn (None when too many)."""
    if p.choices:
        return np.array([float(c) for c in p.choices], float)
    n = _steps(p)
    return np.array([_stepped(p, i) for i in range(n + 1)], float) if n < TABLE_MAX else None


@dataclass
class Variant:
    """One student's values of a problem and their solution.

    ``values`` are the sampled (non-derived) parameter values; the solution is row ``index`` of
    ``batch`` (solved once, with every variant drawn with it), ``result`` that row as a `Result`.
    """

    problem: Problem
    values: dict[str, float]
    seed: int | None
    draws: int
    batch: ResultBatch = field(repr=False, compare=False)
    index: int = 0
    batch_values: dict | None = field(default=None, repr=False, compare=False)
    redraw: int = 0

    @cached_property
    def result(self) -> Result:
        """This variant's row of its batch as a `Result` (made on first use, then kept)."""
        return self.batch.take(self.index)


def _evaluate_rows(text: str, values: dict, n: int) -> np.ndarray:
    """A constraint expression for every variant; a row without a real value counts as False."""
    return np.broadcast_to(expr.truth(expr.evaluate_many(text, values)), (n,))


def _grashof(problem: Problem, full: dict, n: int) -> np.ndarray:
    """True where a four-bar variant violates the problem's Grashof requirement."""
    ctx = Context(problem, full, n)
    crank, coupler, rocker, frame = KINDS[problem.kind].loop
    lens = {
        k: np.broadcast_to(ctx.si(problem.geometry[k], "length", k), (n,)) for k in (crank, coupler, rocker, frame)
    }
    stack = np.stack(list(lens.values()))
    s, l_ = stack.min(axis=0), stack.max(axis=0)
    pq = stack.sum(axis=0) - s - l_
    want = problem.constraints.grashof
    grashof = s + l_ <= pq
    if want == "non-grashof":
        return grashof
    bad = ~grashof
    if want == "crank-rocker":
        bad |= s != lens[crank]
    if want == "double-crank":
        bad |= s != lens[frame]
    return bad


_DRIVER = re.compile(r"^-?driver(@[^.\s]+)?$")


def torque_arms(problem: Problem, batch: ResultBatch) -> dict[str, np.ndarray]:
    """For each torque answer of a crank-driven problem (``driver`` or a superposition part ``driver@g``),
    its share of the moment the largest force of its force polygon would have at the crank pin,
    |T| / (F_max · r): a graphical torque is the pin force's component across the crank, read off that
    polygon, times the pin radius r (`gradekit.solving.tolerances.ARM_MIN`). A total is the sum of its parts,
    each read off its own polygon: its share is of the sum of the parts' moments."""
    out: dict[str, np.ndarray] = {}
    if problem.driver != "crank":
        return out
    lab = problem.label
    for a in batch.answer_list:
        m = _DRIVER.match(a.spec.of.replace(" ", ""))
        if m is None:
            continue
        case = next(c for c in batch.cases if c.name == a.case)
        link = case.solutions.linkage
        drv = link.driver.body
        origin = link.bodies[drv].origin
        revolute = [j for j in link.joints if not isinstance(j, Prismatic)]
        pins = [j for j in revolute if drv in (j.a, j.b) and GROUND not in (j.a, j.b)]
        if not pins:
            continue
        radius = np.maximum.reduce([np.hypot(j.point.x.v - origin.x.v, j.point.y.v - origin.y.v) for j in pins])
        parts = [m.group(1)] if m.group(1) else [k[len("driver"):] for k in case.results if k.startswith("driver@")]
        moment = 0.0
        for part in parts or [""]:
            forces = [np.abs(case.results[f"F[{lab(j.a)},{lab(j.b)}]{part}.mag"][0]) for j in revolute]
            moment = moment + np.maximum.reduce(forces) * radius
        torque = np.abs(case.results["driver" + (m.group(1) or "")][0])
        with np.errstate(divide="ignore", invalid="ignore"):
            out[a.key] = np.where(moment > 0, torque / moment, 1.0)
    return out


def check_many(problem: Problem, values: dict, n: int) -> tuple[np.ndarray, ResultBatch]:
    """Solve a batch of draws and test every constraint.

    Returns:
        The rejecting constraint of each draw (None where accepted; the first that fails, in the
        order: derived values, require, Grashof, assembly/conditioning, virtual work, condition
        bound, transmission angle, dead centre, gradable, distinguish, answer spread), and the batch.
    """
    c = problem.constraints
    batch = solve_many(problem, values, n)
    reasons = np.full(n, None, dtype=object)

    def reject(mask, text) -> None:
        mask = np.broadcast_to(mask, (n,)) & (reasons == None)  # noqa: E711 (elementwise)
        if isinstance(text, str):
            reasons[mask] = text
        else:
            for i in np.flatnonzero(mask):
                reasons[i] = text(i)

    refused = batch.refused.mask
    if refused.any():
        derived = np.array([bool(refused[i]) and batch.reason(i).startswith("derived: ") for i in range(n)])
        reject(derived, lambda i: ": ".join(batch.reason(i).split(": ")[:2]))
    full = batch.values
    for text, message in c.require:
        reject(~_evaluate_rows(text, full, n), f"require: {message or text}")
    kind = KINDS[problem.kind]
    if kind.loop and c.grashof:
        reject(_grashof(problem, full, n), "grashof")
    reject(refused, lambda i: "assembles" if "assembled" in batch.reason(i) else "conditioning")
    ok = ~refused
    with np.errstate(invalid="ignore"):
        reject(ok & (batch.virtual_work_residual > VW_LIMIT), "virtual_work")
        reject(ok & batch.condition_above(c.condition_max), "condition_max")
        reject(ok & (batch.transmission_angle < c.transmission_min), "transmission_min")
        if c.dead_centre_min and kind.dead_centre:
            pivot, pin, end = kind.dead_centre
            for case in batch.cases:
                pts = case.solutions.linkage.points
                crank = (pts[pin].x.v - pts[pivot].x.v, pts[pin].y.v - pts[pivot].y.v)
                rod = (pts[end].x.v - pts[pin].x.v, pts[end].y.v - pts[pin].y.v)
                cross = crank[0] * rod[1] - crank[1] * rod[0]
                dot = crank[0] * rod[0] + crank[1] * rod[1]
                ang = np.degrees(np.abs(np.arctan2(cross, dot)))
                reject(ok & (np.minimum(ang, 180 - ang) < c.dead_centre_min), "dead_centre_min")
        if problem.method == "graphical" and c.gradable:
            for key, share in torque_arms(problem, batch).items():
                spec = next(a.spec for a in batch.answer_list if a.key == key)
                if not spec.hand_check:  # a torque checked by hand is not judged by the rule
                    reject(ok & (share < ARM_MIN), f"gradable: {key} (pin force nearly along the crank)")
        if c.gradable:
            for a in batch.answer_list:
                if a.unit != "deg" and not a.spec.hand_check:
                    reject(ok & (np.abs(a.value) < c.gradable * c.band(a)), f"gradable: {a.key}")
        if c.distinguish:
            found = mistakes_many(batch, values, rows=reasons == None)  # noqa: E711 (the draws not yet rejected)
            for name, keys in c.distinguish:
                for k in keys:
                    for a in (x for x in batch.answer_list if x.key == k or x.key.startswith(k + "_")):
                        m = next((m for m in found.get(a.key, []) if m.name == name), None)
                        if m is None:
                            gap = np.zeros(n)
                        else:
                            gap = np.where(m.changed, np.abs(a.spec.tolerance.difference(m.value, a.value)), 0.0)
                        reject(ok & (gap < c.distinguish_factor * c.band(a)), f"distinguish: {name} on {k}")
        if c.answer_min_fraction:
            by_unit: dict[str, list[np.ndarray]] = {}
            for a in batch.answer_list:
                if a.unit != "deg":
                    by_unit.setdefault(units.si_unit(a.unit), []).append(np.abs(a.value))
            for vals in by_unit.values():
                lo, hi = np.minimum.reduce(vals), np.maximum.reduce(vals)
                reject(ok & (lo < c.answer_min_fraction * hi), "answer_min_fraction")
    return reasons, batch


def check(problem: Problem, values: dict[str, float]) -> tuple[str | None, Result | None]:
    """Solve *values* and test every constraint; return (rejecting constraint or None, result)."""
    reasons, batch = check_many(problem, values, 1)
    try:
        result = batch.take(0)
    except GradekitError:
        result = None
    return reasons[0], result


@dataclass
class VariantBatch:
    """Many variants of one problem (one per seed), each the first accepted draw of its generator.

    ``values[name]`` and ``answers[key]`` are arrays in the order of the seeds; ``ok`` is False for
    a seed that found no acceptable draw within ``max_draws`` (``reason(i)`` says which constraint
    rejected it most). ``variant(i)`` is one of them as a `Variant`.
    """

    problem: Problem
    seeds: list[int | None]
    values: dict[str, np.ndarray]
    draws: np.ndarray
    ok: np.ndarray
    rows: list[tuple[ResultBatch, int, dict] | None]
    failures: dict[int, Counter]
    redraws: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def __len__(self) -> int:
        return len(self.seeds)

    def reason(self, i: int) -> str:
        rejected = self.failures.get(i)
        if not rejected:
            return ""
        worst, count = rejected.most_common(1)[0]
        return (
            f"expected an acceptable variant within {int(self.draws[i])} draws, got none: "
            f"constraint {worst!r} rejected {count} of them ({dict(rejected)})"
        )

    def by_batch(self) -> list[tuple[ResultBatch, list[int]]]:
        """The solved batches of the accepted variants, each with the rows of it they hold."""
        out: dict[int, tuple[ResultBatch, list[int]]] = {}
        for i, row in enumerate(self.rows):
            if row is not None and self.ok[i]:
                out.setdefault(id(row[0]), (row[0], []))[1].append(row[1])
        return list(out.values())

    @property
    def answers(self) -> dict[str, np.ndarray]:
        """Every answer of every variant (NaN where not ok), in the answer's unit."""
        out: dict[str, np.ndarray] = {}
        for i, row in enumerate(self.rows):
            if row is None:
                continue
            batch, j, _ = row
            for a in batch.answer_list:
                out.setdefault(a.key, np.full(len(self), np.nan))[i] = a.value[j]
        return out

    def variant(self, i: int) -> Variant:
        """Variant *i*; raises `SamplingError` when it found no acceptable draw."""
        if not self.ok[i]:
            raise SamplingError(self.reason(i), path=self.problem.path, field="constraints")
        batch, j, raw = self.rows[i]
        values = {k: float(v[i]) for k, v in self.values.items()}
        redraw = int(self.redraws[i]) if len(self.redraws) else 0
        return Variant(self.problem, values, self.seeds[i], int(self.draws[i]), batch, j, raw, redraw)


def sample_many(
    problem: Problem,
    seeds: list[int] | range | None = None,
    *,
    course: str = "",
    salt: str = "",
    students: list[str] | None = None,
    redraws: list[int] | None = None,
    max_draws: int = MAX_DRAWS,
) -> VariantBatch:
    """Draw one variant per seed (or per student of a course and salt), checked in batches.

    Each seed's generator draws until a draw passes every constraint; all pending draws of a
    round are solved together, so a class costs a few batched solves, not one solve per draw.
    A round draws each pending seed's next candidates (several when few seeds are pending) and
    keeps its first acceptable one: the values, the draw count and, for a seed that finds none
    within *max_draws*, the rejections counted are those of one draw at a time.
    """
    if seeds is None:
        students = list(students or [])
        rd = list(redraws or [0] * len(students))
        seeds = [derive_seed(course, salt, s, problem.id, r) for s, r in zip(students, rd, strict=True)]
    seeds = list(seeds)
    n = len(seeds)
    base = published_values(problem)
    randoms = [p for p in problem.parameters.values() if p.random]
    values = {k: np.full(n, v, float) for k, v in base.items()}
    draws = np.zeros(n, int)
    ok = np.zeros(n, bool)
    rows: list = [None] * n
    failures: dict[int, Counter] = {}
    if not randoms:  # every seed gets the published values
        batch = solve_many(problem, base, 1)
        batch.take(0)  # raises the geometry error of a published variant that cannot be solved
        rows = [(batch, 0, base)] * n
        everyone = np.ones(n, bool)
        return VariantBatch(problem, seeds, values, draws, everyone, rows, failures, np.array(redraws or [0] * n))
    drawer = _Drawer(randoms)
    rngs = [np.random.default_rng(s) for s in seeds]
    used = np.zeros(n, int)  # draws each seed's generator has made
    pending = np.arange(n) if max_draws > 0 else np.arange(0)
    tried = passed = 0
    while len(pending):
        # Each pending seed draws `per` candidates (its next draws, in order): enough rows to be worth a
        # solve, no more than a few times the draws an acceptance is expected to take.
        rate = (passed + 1) / (tried + 2)
        per = max(1, min(-(-ROUND_ROWS // len(pending)), math.ceil(4 / rate)))
        counts = np.minimum(per, max_draws - used[pending])
        block = drawer.rows([rngs[i] for i in pending], counts)
        m = len(block)
        cand = {k: np.full(m, v, float) for k, v in base.items()}
        for j, p in enumerate(randoms):
            cand[p.name] = block[:, j].copy()
        reasons, batch = check_many(problem, cand, m)
        good = (reasons == None) & batch.ok  # noqa: E711 (elementwise)
        tried, passed = tried + m, passed + int(good.sum())
        starts = np.cumsum(counts) - counts
        first = np.minimum.reduceat(np.where(good, np.arange(m), m), starts)  # each seed's first accepted row
        hit = first < m
        for i, j in zip(pending[hit], first[hit], strict=True):
            ok[i] = True
            rows[i] = (batch, int(j), cand)
        for p in randoms:
            values[p.name][pending[hit]] = cand[p.name][first[hit]]
        draws[pending[hit]] = used[pending[hit]] + first[hit] - starts[hit] + 1
        for i, s, c in zip(pending[~hit], starts[~hit], counts[~hit], strict=True):
            failures.setdefault(int(i), Counter()).update(r or "unknown" for r in reasons[s : s + c])
        used[pending[~hit]] += counts[~hit]
        draws[pending[~hit]] = used[pending[~hit]]
        pending = pending[~hit][used[pending[~hit]] < max_draws]
    for i in range(n):
        if ok[i]:
            failures.pop(i, None)
    return VariantBatch(problem, seeds, values, draws, ok, rows, failures, np.array(redraws or [0] * n))


def variant(
    problem: Problem,
    *,
    course: str = "",
    salt: str = "",
    student: str | None = None,
    seed: int | None = None,
    redraw: int = 0,
    max_draws: int = MAX_DRAWS,
) -> Variant:
    """The variant of *problem* for *student* (or *seed*); the published one when both are None.

    Raises:
        SamplingError: no acceptable draw in *max_draws*; names the constraint that rejected most.
    """
    base = published_values(problem)
    if student is None and seed is None:
        reasons, batch = check_many(problem, base, 1)
        batch.take(0)  # raises the geometry error of a published variant that cannot be solved
        return Variant(problem, base, None, 0, batch, 0, base)
    if seed is None:
        seed = derive_seed(course, salt, student or "", problem.id, redraw)
    v = sample_many(problem, [seed], max_draws=max_draws).variant(0)
    v.redraw = redraw
    return v


def given(problem: Problem, values: dict[str, float], *, seed: int | None = None, redraw: int = 0) -> Variant:
    """The variant with these drawn *values* (as recorded when it was drawn), solved: no re-draw."""
    batch = solve_many(problem, values, 1)
    batch.take(0)  # raises the variant's geometry error
    return Variant(problem, dict(values), seed, 0, batch, 0, dict(values), redraw)


def class_variants(
    problem: Problem,
    course: str,
    salt: str,
    students: list[str],
    redraws: dict[str, int] | None = None,
    frozen: bool = False,
    limit: int = 50,
) -> dict[str, Variant]:
    """Every student's variant, no two alike.

    A student starts at re-draw counter ``redraws[s]`` (0 by default: an instructor's explicit
    re-draw of one student changes only that student's seed). A student whose values repeat an
    earlier student's (in roster order) is re-drawn with the next counter, unless *frozen* (the
    counters come from a manifest and are reproduced exactly). The whole class is drawn in one
    batch; only the re-draws of repeated values are drawn one by one.
    """
    start = [(redraws or {}).get(s, 0) for s in students]
    vb = sample_many(problem, course=course, salt=salt, students=students, redraws=start)
    out: dict[str, Variant] = {}
    seen: set[tuple] = set()
    randoms = any(p.random for p in problem.parameters.values())
    for i, s in enumerate(students):
        r = start[i]
        v = vb.variant(i)
        key = tuple(sorted(v.values.items()))
        while randoms and key in seen and r < limit and not frozen:
            r += 1
            v = variant(problem, course=course, salt=salt, student=s, redraw=r)
            key = tuple(sorted(v.values.items()))
        v.redraw = r
        seen.add(key)
        out[s] = v
    return out
