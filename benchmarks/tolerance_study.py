"""Tolerances from measurement: simulated honest students against the catalogued mistakes.

For one bank problem the study draws variants spread over the problem's sampling space (the
sampler's own `gradekit.solving.sampling.sample_many`, so only variants a student can get) and, for every
variant, *K* honest students per model, all solved in batches:

* ``sf3``, ``sf4``: honest analytical work to 3 and to 4 significant figures. Every given value
  and every intermediate a student writes down (link angles in degrees, angular velocities and
  accelerations, joint coordinates) carries an independent uniform error of ±0.5 unit in its last
  kept digit; the mechanics are re-solved with them and the answer is written to that many figures.
* ``drawing`` (graphical problems): the construction a student makes on the printed sheet.
  The mechanism is printed at its printed scale *k* (`gradekit.figures.sheet.printed_scale`:
  paper length per mechanism length); every point the student takes off the sheet (pivots, pins,
  link ends, where a load acts) is off by up to ±``READ_MM`` mm on paper in x and in y, so every
  line of action through those points is off as the sheet makes it; every direction laid off with
  a protractor (link directions, the directions of the given forces) is off by up to ±``READ_DEG``°.
  Velocity and acceleration polygons (dynamic problems) and the force polygon are drawn at the
  scale a student would choose: the 1-2-5 series scale that puts the largest vector between
  ``POLYGON_MM / 2.5`` and ``POLYGON_MM`` mm; each vector is laid off and read to ±``READ_MM`` mm at
  that scale (given forces drawn, unknown forces and rates read). A torque is the moment of the
  force at the driven link's moving pin about its pivot: that force's component across the link
  read off the polygon (±``READ_MM`` mm; the link's direction laid off to ±``READ_DEG``°) times
  the pin's radius (a given dimension); a length is measured on the sheet; an angle is read to
  ±``READ_DEG``°. The answer is written to 3 significant figures.
* every catalogued mistake (`gradekit.solving.mistakes.mistakes_many`, re-solved) and every generic one
  (`gradekit.grading.compare.generic_mistakes`: sign, ×/÷1000, deg/rad).

Scoring uses the grader's own acceptance, `Tolerance.accepts_many` (floor resolved per variant
from the variant's scale, 360° wrap for angles): one rule measured and applied. The false-reject
rate is stated with its one-sided 95 % Clopper–Pearson upper bound; `choose` picks per answer the
narrowest band whose upper bound is below 0.1 % for every honest model. Honest students win: a
mistake that band cannot catch ≥ 99 % of the time is reported as undetectable, never traded for
a band that rejects honest work (nor is a wider band chosen to catch it).

Nothing here patches gradekit: the study builds, perturbs and solves the student's linkage through
gradekit's public pieces (`pipeline.build_linkage`, `build_analysis`, `mechanics.forces.solve_many`,
`pipeline.flat_results`), passed what they need explicitly.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from gradekit import units
from gradekit.bank.model import Problem
from gradekit.errors import GradekitError
from gradekit.grading.compare import generic_mistakes
from gradekit.mechanics import forces
from gradekit.mechanics.jet import Jet, P
from gradekit.mechanics.model import GROUND, Linkage, Refusals
from gradekit.solving import pipeline
from gradekit.solving.keys import KeyEntry, Tolerance
from gradekit.solving.mistakes import mistakes_many
from gradekit.solving.sampling import sample_many
from gradekit.solving.tolerances import POLYGON_MM as POLYGON_RANGE
from gradekit.solving.tolerances import READ_DEG, READ_MM, answer_kind

MODELS = ("sf3", "sf4", "drawing")
FALSE_REJECT_MAX = 0.001  # the upper bound of the honest false-reject rate must be below this
CONFIDENCE = 0.95
DETECT_MIN = 0.99
POLYGON_MM = POLYGON_RANGE[1]  # the largest vector of a polygon is drawn between 60 and 150 mm (1-2-5 scale)
REL_GRID = (
    0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.025, 0.03, 0.04, 0.05, 0.06, 0.075,
    0.1, 0.125, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.75, 1.0,
)  # fmt: skip
# floor: a fraction of the variant's scale
FLOOR_GRID = (0.0, 0.001, 0.003, 0.01, 0.02, 0.03, 0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0)
DEG_GRID = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 7.5, 10.0, 15.0)


# --- statistics ------------------------------------------------------------------------------


@functools.cache
def upper_bound(k: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper–Pearson upper bound of a rate seen *k* times in *n* (0 of n: 1 − (1−c)^(1/n)).

    Exact for k ≤ 200; above, where the bound is far beyond 0.1 % anyway, the Wilson score bound."""
    if n <= 0 or k >= n:
        return 1.0
    alpha = 1.0 - confidence
    if k > 200:
        z = 1.6448536269514722
        ph = k / n
        c = ph + z * z / (2 * n) + z * math.sqrt(ph * (1 - ph) / n + z * z / (4 * n * n))
        return min(1.0, c / (1 + z * z / n))
    i = np.arange(k + 1)
    logc = np.array([math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1) for j in range(k + 1)])

    def cdf(p: float) -> float:  # P(X <= k) for X ~ Binomial(n, p)
        return float(np.exp(logc + i * math.log(p) + (n - i) * math.log1p(-p)).sum())

    lo, hi = k / n, 1.0
    for _ in range(80):
        mid = (lo + hi) / 2
        if cdf(mid) > alpha:
            lo = mid
        else:
            hi = mid
    return hi


# --- perturbation models ---------------------------------------------------------------------


def nice_scale(biggest: np.ndarray, length_mm: float = POLYGON_MM) -> np.ndarray:
    """Units per paper mm: the smallest 1-2-5 series value drawing *biggest* at most *length_mm* long."""
    need = np.maximum(np.abs(biggest), 1e-300) / length_mm
    e = np.floor(np.log10(need))
    out = np.full(np.shape(need), np.inf)
    for m in (1.0, 2.0, 5.0, 10.0):
        s = m * 10.0**e
        out = np.where((s >= need * (1 - 1e-12)) & (s < out), s, out)
    return out


def sf_error(v, sig: int, rng: np.random.Generator):
    """*v* with a uniform error of ±0.5 unit in its last kept digit (of *sig* significant figures)."""
    v = np.asarray(v, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ulp = np.where(v != 0, 10.0 ** (np.floor(np.log10(np.abs(np.where(v != 0, v, 1.0)))) - sig + 1), 0.0)
    return v + rng.uniform(-0.5, 0.5, np.shape(v)) * ulp


def sig_round(x, sig: int):
    """Round to *sig* significant figures, elementwise."""
    x = np.asarray(x, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        mag = np.where((x != 0) & np.isfinite(x), np.floor(np.log10(np.abs(np.where(x != 0, x, 1.0)))), 0.0)
    f = 10.0 ** (sig - 1 - mag)
    return np.where(np.isfinite(x) & (x != 0), np.round(x * f) / f, x)


@dataclass
class Model:
    """One honest model over a batch of *n* students (see the module docstring).

    ``paper`` is each row's printed scale (paper m per mechanism m), ``rate_mm`` each row's error of a
    rate read off the velocity / acceleration polygon, in rad/s (rad/s²) per body: the polygon's
    units per paper mm times ``READ_MM`` divided by the link's length.
    """

    name: str
    rng: np.random.Generator
    n: int
    paper: np.ndarray | None = None
    omega_err: np.ndarray | None = None
    alpha_err: np.ndarray | None = None

    @property
    def sig(self) -> int:
        return int(self.name[2:]) if self.name.startswith("sf") else 3

    def u(self, half: float | np.ndarray = 1.0) -> np.ndarray:
        return self.rng.uniform(-1.0, 1.0, self.n) * half

    def angle(self, a):
        if self.name == "drawing":
            return a + np.radians(self.u(READ_DEG))
        deg = np.degrees(np.broadcast_to(a, (self.n,))) % 360.0
        return np.radians(sf_error(deg, self.sig, self.rng))

    def rate(self, x, err):
        x = np.broadcast_to(np.asarray(x, float), (self.n,))
        if self.name == "drawing":
            return x + self.u(1.0) * err
        return sf_error(x, self.sig, self.rng)

    def coord(self, x):
        x = np.broadcast_to(np.asarray(x, float), (self.n,))
        if self.name == "drawing":
            return x + self.u(READ_MM * 1e-3) / self.paper
        return sf_error(x, self.sig, self.rng)

    def point(self, p: P) -> P:
        return P(Jet(self.coord(p.x.v), p.x.d, p.x.dd), Jet(self.coord(p.y.v), p.y.d, p.y.dd))

    def linkage(self, link: Linkage) -> Linkage:
        """The student's version of *link*: angles, rates and joint positions as written down / drawn."""
        moved: dict[int, P] = {}
        seen: list[tuple[P, P]] = []  # (point, as written): one point drawn once, however many joints share it

        def mv(p: P) -> P:
            if id(p) not in moved:
                same = next((w for q, w in seen if np.array_equal(q.x.v, p.x.v) and np.array_equal(q.y.v, p.y.v)), None)
                if same is None:
                    same = self.point(p)
                    seen.append((p, same))
                moved[id(p)] = P(Jet(same.x.v, p.x.d, p.x.dd), Jet(same.y.v, p.y.d, p.y.dd))
            return moved[id(p)]

        bodies = {}
        for name, b in link.bodies.items():
            ang = b.angle
            if name != link.input_body:
                ang = Jet(self.angle(ang.v), self.rate(ang.d, self.omega_err), self.rate(ang.dd, self.alpha_err))
            bodies[name] = replace(b, origin=mv(b.origin), angle=ang)
        joints = tuple(replace(j, point=mv(j.point)) for j in link.joints)
        points = {k: mv(p) for k, p in link.points.items()}
        return replace(link, bodies=bodies, joints=joints, points=points)


def _given(problem: Problem, values: dict[str, np.ndarray], model: Model, force_unit: np.ndarray) -> dict:
    """The student's version of the given values (*force_unit*: the force polygon's N per paper mm)."""
    out = dict(values)
    for name, v in values.items():
        p = problem.parameters.get(name)
        if p is None or p.expr:
            continue
        v = np.broadcast_to(np.asarray(v, float), (model.n,))
        if model.name != "drawing":
            out[name] = sf_error(v, model.sig, model.rng)
            continue
        si = units.si_unit(p.unit)
        if si == units.si_unit("m"):  # where a load acts, located on the sheet
            out[name] = v + units.convert(model.u(READ_MM * 1e-3) / model.paper, "m", p.unit)
        elif si == units.si_unit("deg"):  # a direction laid off with a protractor
            out[name] = v + units.convert(model.u(READ_DEG), "deg", p.unit)
        elif si == units.si_unit("N"):  # a given force laid off in the polygon
            out[name] = v + units.convert(model.u(READ_MM) * force_unit, "N", p.unit)
    return out


# --- solving the students' work --------------------------------------------------------------


def _answers(problem: Problem, cases: list[tuple[str | None, dict, pipeline.Results]]) -> dict[str, np.ndarray]:
    """Every answer of the problem from solved cases, in the answer's unit (as `pipeline.solve_many`)."""
    out = {}
    for spec in problem.answers:
        for name, vals, res in cases:
            if spec.case is not None and spec.case != name:
                continue
            key = spec.key if (spec.case is not None or name is None) else f"{spec.key}_{name}"
            if spec.of.startswith("param["):
                pname = spec.of[6:-1]
                out[key] = np.asarray(vals[pname], float) * np.ones(1)
                continue
            si_value, si_unit = res[spec.of]
            out[key] = np.asarray(
                units.convert(si_value, si_unit, spec.unit) if si_unit != "deg" or spec.unit != "deg" else si_value,
                float,
            )
    return out


def solve_students(
    problem: Problem, exact: dict[str, np.ndarray], model: Model, force_unit: np.ndarray
) -> tuple[dict[str, np.ndarray], np.ndarray, list]:
    """Solve *model*'s students: ``exact`` are each row's true given values (arrays of ``model.n``).

    Returns each answer's raw (unread, unrounded) values, the rows refused, and per case the
    (student's linkage, solutions) pair the drawing's torque arms are measured on.
    """
    n = model.n
    given = _given(problem, exact, model, force_unit)
    drawn = exact if model.name == "drawing" else given  # a drawing takes positions off the printed sheet
    cases = []
    bad = Refusals(n)
    solved = []
    overs = problem.cases.items() if problem.cases else [(None, {})]
    for name, over in overs:
        vals = pipeline.fill_many(problem, {**given, **over}, n, bad)
        geo = pipeline.fill_many(problem, {**drawn, **over}, n, bad)
        link = model.linkage(pipeline.build_linkage(problem, geo, n=n))
        link.refused.mask |= bad.mask
        speed = np.broadcast_to(np.asarray(link.bodies[link.input_body].angle.d, float), (n,))
        virtual = None if speed.all() else pipeline.build_linkage(problem, geo, True, n)
        sols = forces.solve_many(link, pipeline.build_analysis(problem, vals, n), virtual)
        bad.mask |= sols.refused.mask
        cases.append((name, vals, pipeline.flat_results(problem, sols)))
        solved.append((name, sols, cases[-1][2]))
    return _answers(problem, cases), bad.mask, solved


# --- the study -------------------------------------------------------------------------------


@dataclass
class AnswerData:
    """Everything simulated for one answer over the variants of a problem."""

    key: str
    of: str
    unit: str
    kind: str
    exact: np.ndarray  # (V,)
    scale: np.ndarray  # (V,) the variant's scale, as the grader resolves floors
    honest: dict[str, np.ndarray]  # model -> (V, K), NaN where the student's solve failed
    mistakes: dict[str, np.ndarray]  # mistake name -> (V,), NaN where it does not apply


@dataclass
class Study:
    problem: Problem
    method: str
    variants: int
    per_variant: int
    answers: dict[str, AnswerData]
    failures: dict[str, int] = field(default_factory=dict)  # model -> students whose solve was refused
    models: tuple[str, ...] = ()  # the honest models a band must admit (`basis` at the sheet's precision)


def merge(a: AnswerData, b: AnswerData) -> AnswerData:
    """One answer's data over the variants of *a* and then those of *b* (the cases of one answer)."""
    names = list(dict.fromkeys([*a.mistakes, *b.mistakes]))
    nan_a, nan_b = np.full(len(a.exact), np.nan), np.full(len(b.exact), np.nan)
    return AnswerData(
        a.key,
        a.of,
        a.unit,
        a.kind,
        np.concatenate([a.exact, b.exact]),
        np.concatenate([a.scale, b.scale]),
        {m: np.concatenate([a.honest[m], b.honest[m]]) for m in a.honest if m in b.honest},
        {n: np.concatenate([a.mistakes.get(n, nan_a), b.mistakes.get(n, nan_b)]) for n in names},
    )


def basis(method: str, sigfigs: int = 3) -> tuple[str, ...]:
    """The honest models a band must admit: work to the significant figures the sheet asks for
    (``sigfigs`` of the problem) and one more, and drawings for graphical problems."""
    sf = (f"sf{sigfigs}", f"sf{sigfigs + 1}")
    return (*sf, "drawing") if method == "graphical" else sf


def _printed(problem: Problem, vb, rows: np.ndarray, printed_scale: Callable | None) -> np.ndarray:
    if printed_scale is None or not problem.figure.true_scale:
        return np.full(len(rows), float(problem.figure.true_scale or 1.0))
    return np.array([printed_scale(vb.variant(int(i)).result) or problem.figure.true_scale for i in rows], float)


def simulate(
    problem: Problem,
    n_variants: int = 500,
    per_variant: int = 10,
    seed: int = 373,
    models: tuple[str, ...] | None = None,
    printed_scale: Callable | None = None,
) -> Study:
    """Draw variants of *problem* and simulate every honest model and every mistake on each.

    *printed_scale* (`gradekit.figures.sheet.printed_scale`) gives a variant's printed scale;
    without it the drawing uses ``figure.true_scale``. A problem without random parameters has one
    variant and ``n_variants × per_variant`` students of it.
    """
    models = tuple(
        m for m in (models or basis(problem.method, problem.sigfigs)) if m != "drawing" or problem.method == "graphical"
    )
    randoms = any(p.random for p in problem.parameters.values())
    seeds = [seed * 1_000_003 + s for s in range(n_variants)] if randoms else [None]
    vb = sample_many(problem, seeds)
    rows = np.flatnonzero(vb.ok)
    if not len(rows):
        raise GradekitError(f"{problem.id}: no variant could be drawn")
    nv = len(rows)
    k = per_variant if randoms else per_variant * n_variants
    exact: dict[str, np.ndarray] = {}
    scale: dict[str, np.ndarray] = {}
    meta: dict[str, object] = {}
    mist: dict[str, dict[str, np.ndarray]] = {}
    groups: dict[int, tuple] = {}
    for j, i in enumerate(rows):
        batch, r, raw = vb.rows[int(i)]
        g = groups.setdefault(id(batch), (batch, raw, [], []))
        g[2].append(j)
        g[3].append(r)
    for batch, raw, idx, sel in groups.values():
        idx, sel = np.array(idx), np.array(sel)
        found = mistakes_many(batch, raw)
        for a in batch.answer_list:
            exact.setdefault(a.key, np.full(nv, np.nan))[idx] = np.broadcast_to(a.value, (batch.n,))[sel]
            scale.setdefault(a.key, np.full(nv, np.nan))[idx] = np.broadcast_to(a.scale, (batch.n,))[sel]
            meta[a.key] = a
            m = mist.setdefault(a.key, {})
            for mb in found.get(a.key, []):
                col = m.setdefault(mb.name, np.full(nv, np.nan))
                changed, value = (np.broadcast_to(x, (batch.n,))[sel] for x in (mb.changed, mb.value))
                col[idx] = np.where(changed, value, np.nan)
    # generic mistakes are linear in the key value: their factor is the mistake of a key of 1
    for key, a in meta.items():
        for mk in generic_mistakes(KeyEntry("", problem.id, key, 1.0, a.unit, Tolerance())):
            if mk.name not in mist[key]:
                vals = exact[key] * mk.value
                mist[key][mk.name] = np.where(exact[key] != 0, vals, np.nan) if mk.name == "sign flipped" else vals
    # every honest student: row v * k + j is student j of variant v
    base = {name: np.repeat(np.asarray(vb.values[name], float)[rows], k) for name in vb.values}
    n = nv * k
    rng = np.random.default_rng(seed)
    honest = {key: {} for key in exact}
    failures = {}
    units_of = {key: a.unit for key, a in meta.items()}
    forces_n = [
        np.abs(units.to_si(exact[key], u))
        for key, u in units_of.items()
        if units.si_unit(u) == units.si_unit("N") and not meta[key].spec.of.endswith((".x", ".y"))
    ]
    biggest_force = np.repeat(np.maximum.reduce(forces_n) if forces_n else np.ones(nv), k)
    force_unit = nice_scale(biggest_force)  # N per paper mm of the force polygon
    paper = np.repeat(_printed(problem, vb, rows, printed_scale), k) if "drawing" in models else None
    for m in models:
        model = Model(m, rng, n, paper)
        if m == "drawing":
            model.omega_err, model.alpha_err = _rate_errors(problem, vb, rows, k)
        try:
            raw_ans, refused, solved = solve_students(problem, base, model, force_unit)
        except GradekitError:
            failures[m] = n
            continue
        failures[m] = int(refused.sum())
        for key in exact:
            x = np.where(refused, np.nan, np.broadcast_to(raw_ans[key], (n,)))
            kind = answer_kind(meta[key].spec.of, units_of[key])
            if m == "drawing":
                x = _read(problem, model, x, kind, units_of[key], meta[key], solved, force_unit, exact, units_of, k)
            x = sig_round(x, model.sig)
            if kind == "angle":
                x = x % 360.0
            honest[key][m] = x.reshape(nv, k)
    answers: dict[str, AnswerData] = {}
    for key in exact:  # an answer asked in every case (key_case) is one answer of the file: merged
        spec = meta[key].spec
        a = AnswerData(
            spec.key,
            spec.of,
            units_of[key],
            answer_kind(spec.of, units_of[key]),
            exact[key],
            scale[key],
            honest[key],
            mist[key],
        )
        answers[spec.key] = merge(answers[spec.key], a) if spec.key in answers else a
    return Study(problem, problem.method, nv, k, answers, failures, models)


def _rate_errors(problem: Problem, vb, rows: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Error of a link's ω (α) read off a velocity (acceleration) polygon drawn at a nice scale:
    ±READ_MM at the polygon's m/s (m/s²) per mm, divided by the link's length (the polygon gives a
    relative velocity; ω = v / L). Uses the variant's largest point speed (acceleration)."""
    om, al = [], []
    for r in rows:
        res = vb.variant(int(r)).result
        vmax = amax = 0.0
        lmin = math.inf
        for c in res.cases:
            link = c.solution.linkage
            for p in link.points.values():
                vmax = max(vmax, math.hypot(float(p.x.d), float(p.y.d)))
                amax = max(amax, math.hypot(float(p.x.dd), float(p.y.dd)))
            lmin = min([lmin, *(float(v) for v in link.lengths.values() if float(v) > 0)] or [float(link.scale)])
        lmin = lmin if math.isfinite(lmin) else 1.0
        om.append(READ_MM * float(nice_scale(np.array(vmax))) / lmin)
        al.append(READ_MM * float(nice_scale(np.array(amax))) / lmin)
    return np.repeat(om, k), np.repeat(al, k)


def _read(problem, model: Model, x, kind, unit, meta, solved, force_unit, exact, units_of, k) -> np.ndarray:
    """A drawing's reading of answer values *x* (see the module docstring)."""
    u = model.u
    if kind == "angle":
        return (x + u(READ_DEG)) % 360.0
    if kind == "length":
        return x + units.convert(u(READ_MM * 1e-3) / model.paper, "m", unit)
    part = meta.spec.of[meta.spec.of.index("@") :].split(".")[0] if "@" in meta.spec.of else ""
    _, sols, results = next((s for s in solved if s[0] == meta.case), solved[0])
    if part:  # a superposition part has its own polygon, drawn at its own scale
        names = [nm for nm in results if nm.startswith("F[") and nm.endswith(part + ".mag")]
        biggest = [np.abs(np.broadcast_to(results[nm][0], (model.n,))) for nm in names]
        force_unit = nice_scale(np.maximum.reduce(biggest)) if biggest else force_unit
    if kind in ("force", "force-component"):
        return x + units.convert(u(READ_MM) * force_unit, "N", unit)
    if kind == "torque":
        # T = F_t · r: the moment of the force at the driven link's moving pin (from the polygon of
        # the same superposition part) about its pivot, F_t its component across the link read off
        # the polygon (±READ_MM mm at the polygon's scale; the link's direction laid off to
        # ±READ_DEG°), r the pin's radius (a given dimension).
        link = sols.linkage
        drv, lab = link.driver.body, problem.label
        origin = link.bodies[drv].origin
        pins, radii = [np.zeros(model.n)], [np.broadcast_to(np.asarray(link.scale, float), (model.n,))]
        for j in link.joints:
            name = f"F[{lab(j.a)},{lab(j.b)}]{part}.mag" if not hasattr(j, "axis") else ""
            if name in results and drv in (j.a, j.b) and GROUND not in (j.a, j.b):
                pins.append(np.broadcast_to(results[name][0], (model.n,)))
                radii.append(np.hypot(j.point.x.v - origin.x.v, j.point.y.v - origin.y.v))
        k_pin = np.argmax(np.stack(pins), axis=0)
        radius = np.choose(k_pin, np.stack(radii))
        pin = np.maximum(np.choose(k_pin, np.stack(pins)), np.abs(units.to_si(x, unit)) / np.maximum(radius, 1e-12))
        err = (u(READ_MM) * force_unit + u(1.0) * pin * math.radians(READ_DEG)) * radius  # N·m
        return x + units.convert(err, "N*m", unit)
    # kinematic: read off the velocity / acceleration polygon drawn at its nice scale
    same = [exact[key] for key, un in units_of.items() if un == unit]
    biggest = np.repeat(np.maximum.reduce([np.abs(v) for v in same]), k)
    return x + u(READ_MM) * nice_scale(biggest)


# --- scoring ---------------------------------------------------------------------------------


@dataclass
class Score:
    tolerance: Tolerance
    rejected: dict[str, int]  # model -> honest answers rejected
    samples: dict[str, int]  # model -> honest answers
    detection: dict[str, float]  # mistake -> rate

    def rate(self, m: str) -> float:
        return self.rejected[m] / max(self.samples[m], 1)

    def bound(self, m: str) -> float:
        return upper_bound(self.rejected[m], self.samples[m])

    def worst_bound(self) -> float:
        return max((self.bound(m) for m in self.samples), default=0.0)

    def worst_detection(self) -> float:
        return min(self.detection.values(), default=1.0)


def evaluate(a: AnswerData, tol: Tolerance, models: tuple[str, ...]) -> Score:
    """False rejects per honest model and detection rate per mistake of *tol* on *a*, scored by the
    grader's `Tolerance.accepts_many` (floor resolved per variant, angles wrapped)."""
    rej, cnt = {}, {}
    for m in models:
        h = a.honest.get(m)
        if h is None:
            continue
        good = np.isfinite(h)
        ok = tol.accepts_many(h, a.exact[:, None], a.scale[:, None])
        rej[m], cnt[m] = int((~ok & good).sum()), int(good.sum())
    det = {}
    for name, vals in a.mistakes.items():
        live = np.isfinite(vals) & np.isfinite(a.exact)
        if live.any():
            caught = ~tol.accepts_many(vals[live], a.exact[live], a.scale[live])
            det[name] = float(caught.mean())
    return Score(tol, rej, cnt, det)


def candidates(kind: str) -> Iterator[Tolerance]:
    """Candidate bands: relative with a floor (a fraction of the variant's scale); degrees for angles."""
    if kind == "angle":
        for d in DEG_GRID:
            yield Tolerance("relative", 0.0, d, period=360.0)
        return
    for rel in REL_GRID:
        for f in FLOOR_GRID:
            yield Tolerance("relative", rel, 0.0, floor=f)


def width(a: AnswerData, tol: Tolerance) -> float:
    """Median half-width of the band relative to the answer (angles: degrees)."""
    if a.kind == "angle":
        return tol.abs
    with np.errstate(invalid="ignore", divide="ignore"):
        w = tol.bands(a.exact, a.scale) / np.abs(a.exact)
    w = w[np.isfinite(w)]
    return float(np.median(w)) if w.size else math.inf


def choose(a: AnswerData, method: str) -> Score:
    """The band for *a*: the narrowest candidate (median half-width relative to the answer) whose
    false-reject upper bound is below 0.1 % for every honest model; of equally narrow ones, the one
    catching most of its worst mistake. Honest students win: a wider band is never chosen to catch a
    mistake, the mistakes it misses are reported. When no candidate is honest enough, the one with
    the fewest rejections (its bound is reported as it is)."""
    cached = a.__dict__.get("_choice")
    if cached is not None and cached[0] == method:
        return cached[1]
    models = basis(method)
    ranked = sorted(((width(a, t), i, t) for i, t in enumerate(candidates(a.kind))), key=lambda x: x[:2])
    best: Score | None = None
    best_w = math.inf
    for w, _i, tol in ranked:  # narrowest first: the first honest one (and any as narrow) decides
        if w > best_w:
            break
        s = evaluate(a, tol, models)
        if s.worst_bound() < FALSE_REJECT_MAX and (best is None or s.worst_detection() > best.worst_detection()):
            best, best_w = s, w
    if best is None:  # no band honest enough: the one with the fewest rejections, then the narrowest
        scored = [(evaluate(a, tol, models), w) for w, _i, tol in ranked]
        best = min(scored, key=lambda sw: (sw[0].worst_bound(), sw[1]))[0]
    a.__dict__["_choice"] = (method, best)
    return best


def honest_errors(a: AnswerData, model: str) -> np.ndarray:
    """Relative (angles: absolute, degrees) errors of the honest answers of *model*, flattened."""
    h = a.honest[model]
    d = h - a.exact[:, None]
    if a.kind == "angle":
        d = (d + 180.0) % 360.0 - 180.0
        return np.abs(d[np.isfinite(d)])
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.abs(d) / np.abs(a.exact[:, None])
    return r[np.isfinite(r)]


@dataclass
class Choice:
    """The outcome for one answer: the chosen band, its rates, the mistakes it cannot catch."""

    problem: str
    method: str
    key: str
    kind: str
    unit: str
    score: Score
    undetectable: dict[str, tuple[float, float]]  # mistake -> (detection, median relative size)


def study_choices(st: Study) -> list[Choice]:
    out = []
    for a in st.answers.values():
        s = choose(a, st.method)
        missed = {}
        for name, rate in s.detection.items():
            if rate < DETECT_MIN:
                with np.errstate(invalid="ignore", divide="ignore"):
                    d = np.abs(a.mistakes[name] - a.exact)
                    if a.kind == "angle":
                        d = np.abs((a.mistakes[name] - a.exact + 180.0) % 360.0 - 180.0)
                    size = d if a.kind == "angle" else d / np.abs(a.exact)
                missed[name] = (rate, float(np.nanmedian(size)))
        out.append(Choice(st.problem.id, st.method, a.key, a.kind, a.unit, s, missed))
    return out


def kind_defaults(studies: list[Study]) -> dict[tuple[str, str], tuple[Tolerance, float, float]]:
    """One band per (method, answer kind), for answers the per-answer table does not cover yet: the
    narrowest candidate (median relative width over the kind's answers) whose false-reject upper
    bound, pooled over every answer of that kind in the bank, is below 0.1 % for every honest model
    (answers that no candidate admits are left out: they are reported on their own). Returns
    (band, pooled upper bound, mean detection of the worst mistake over the kind's answers)."""
    pools: dict[tuple[str, str], list[AnswerData]] = {}
    for st in studies:
        for a in st.answers.values():
            if choose(a, st.method).worst_bound() < FALSE_REJECT_MAX:  # an answer no band can admit: not a guide
                pools.setdefault((st.method, a.kind), []).append(a)
    out = {}
    for (method, kind), answers in sorted(pools.items()):
        models = basis(method)
        ranked = sorted(
            ((float(np.median([width(a, t) for a in answers])), i, t) for i, t in enumerate(candidates(kind))),
            key=lambda x: x[:2],
        )
        best = None
        for _w, _i, tol in ranked:  # narrowest first: the first honest one is the default
            scores = [evaluate(a, tol, models) for a in answers]
            ub = max(  # per model over the answers it was run on (a problem's sheet names its figures)
                upper_bound(sum(s.rejected.get(m, 0) for s in scores), sum(s.samples.get(m, 0) for s in scores))
                for m in models
                if any(m in s.samples for s in scores)
            )
            det = float(np.mean([s.worst_detection() for s in scores]))
            if best is None or ub < best[1]:
                best = (tol, ub, det)
            if ub < FALSE_REJECT_MAX:
                break
        out[(method, kind)] = best
    return out


# --- bands that grade: honest work in, 10 % off out (issue 25) ------------------------------

DISC_REL = (0.005, 0.0075, 0.01, 0.015, 0.02, 0.025, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.095)
DISC_FLOOR = (0.0, 0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08)
DISC_DEG = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5)


@dataclass
class Graded:
    """The band chosen for one answer under the gradability rule: ``band`` (None: no band admits honest
    work and rejects 10 % off; the answer is for hand checking), the variants it keeps gradable
    (``mask``) and its honest bound on them."""

    key: str
    kind: str
    band: Tolerance | None
    mask: np.ndarray  # (V,) variants in which the answer is gradable at this band
    bound: float


def _honest_ok(a: AnswerData, tol: Tolerance, models: tuple[str, ...], rows: np.ndarray) -> tuple[int, int]:
    """Worst model's (rejected, honest answers) of *tol* over variants *rows* of *a*."""
    worst = (0, 0)
    worst_ub = -1.0
    for m in models:
        h = a.honest.get(m)
        if h is None:
            continue
        h = h[rows]
        good = np.isfinite(h)
        ok = tol.accepts_many(h, a.exact[rows, None], a.scale[rows, None])
        k, n = int((~ok & good).sum()), int(good.sum())
        ub = upper_bound(k, n)
        if ub > worst_ub:
            worst, worst_ub = (k, n), ub
    return worst


def gradable_band(a: AnswerData, models: tuple[str, ...], factor: float, within: np.ndarray | None = None) -> Graded:
    """The band for *a* that keeps it gradable in most variants: of the bands no wider than
    ``1/factor`` of the answer (``Constraints.gradable``: the sampler keeps a variant only where every
    answer is at least *factor* bands from zero, so an answer 10 % off can never earn credit), the
    one whose honest false-reject bound over the variants it keeps gradable is below 0.1 %, that
    rejects no honest answer in the variants *within* (those every other answer keeps), and that keeps
    the most of those gradable (then the narrowest). Directions: the narrowest band below 5° so honest
    over every variant and rejecting none within."""
    v = len(a.exact)
    within = np.ones(v, bool) if within is None else within
    if a.kind == "angle":
        everything = np.arange(v)
        for d in DISC_DEG:
            tol = Tolerance("relative", 0.0, d, period=360.0)
            k, n = _honest_ok(a, tol, models, everything)
            if upper_bound(k, n) < FALSE_REJECT_MAX and _honest_ok(a, tol, models, np.flatnonzero(within))[0] == 0:
                return Graded(a.key, a.kind, tol, np.ones(v, bool), upper_bound(k, n))
        return Graded(a.key, a.kind, None, np.ones(v, bool), 1.0)
    passing: list[tuple[float, float, Graded]] = []  # (share kept gradable, median width, choice)
    for rel in DISC_REL:
        for fl in DISC_FLOOR:
            tol = Tolerance("relative", rel, 0.0, floor=fl)
            band = tol.bands(a.exact, a.scale)
            mask = np.abs(a.exact) >= factor * band
            if not mask.any():
                continue
            k, n = _honest_ok(a, tol, models, np.flatnonzero(mask))
            ub = upper_bound(k, n)
            if ub >= FALSE_REJECT_MAX or (k and _honest_ok(a, tol, models, np.flatnonzero(mask & within))[0]):
                continue
            passing.append((float((mask & within).mean()), width(a, tol), Graded(a.key, a.kind, tol, mask, ub)))
    if not passing:
        return Graded(a.key, a.kind, None, np.ones(v, bool), 1.0)
    top = max(p[0] for p in passing)
    # of the bands that keep (nearly) the most variants gradable, the narrowest: it also catches 5 % errors
    return min((p for p in passing if p[0] >= top - 0.01), key=lambda p: p[1])[2]


__all__ = [
    "MODELS",
    "AnswerData",
    "Choice",
    "Score",
    "Study",
    "basis",
    "choose",
    "evaluate",
    "kind_defaults",
    "nice_scale",
    "simulate",
    "study_choices",
    "upper_bound",
]
