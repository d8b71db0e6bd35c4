"""Tolerances from measurement: simulated honest students against the catalogued mistakes.

For one bank problem this module draws many variants (as the sampler does for students) and, for
each, simulates:

* honest analytical work to 3 and to 4 significant figures (``sf3``, ``sf4``): every input
  parameter and every intermediate a student writes down (link angles, angular velocities and
  accelerations, joint coordinates) carries an independent uniform error of ±0.5 unit in the
  last kept digit; the mechanics are re-solved with them and the answer is rounded as written;
* honest graphical work (``graphical``): the drawing at ``figure.true_scale`` (paper mm per
  mechanism mm) has every length and joint position off by up to ±0.5 mm on paper and every
  direction by up to ±0.5°; forces are read off a polygon whose largest force is ~80 mm long
  (±0.5 mm), torques are a force times an arm measured on the drawing (±0.5 mm each), angles are
  read to ±0.5°; the answer is written to 3 significant figures;
* every catalogued mistake (`gradekit.mistakes.catalogued_mistakes`, re-solved) and every
  generic one (`gradekit.grading.compare.generic_mistakes`: sign, ×/÷1000, deg/rad).

`evaluate` scores a tolerance (relative with an absolute floor, the grader's own
`Tolerance.accepts`) by its false-reject rate on honest answers and its detection rate of each
mistake; `choose` picks per answer the tightest tolerance that rejects < 0.1 % of honest answers,
and reports whether every mistake is still caught ≥ 99 % of the time. Where no fixed tolerance
does both, `variant_band` gives a per-variant band from the answer's own sensitivity.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from gradekit import pipeline, units
from gradekit.bank.schema import Problem
from gradekit.errors import GradekitError
from gradekit.keys import KeyEntry, Tolerance
from gradekit.mechanics.jet import Jet, P
from gradekit.mechanics.model import Linkage
from gradekit.sampling import Variant, variant
from gradekit.tolerances import answer_kind

MODELS = ("sf3", "sf4", "graphical")
FALSE_REJECT_MAX = 0.001
DETECT_MIN = 0.99
FORCE_SCALE_MM = 80.0  # the largest force of a polygon, drawn on paper
READ_MM = 0.5
READ_DEG = 0.5
REL_GRID = (0.001, 0.002, 0.003, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.025, 0.03, 0.04, 0.05, 0.075, 0.1, 0.15, 0.2)
FLOOR_GRID = (0.0, 0.001, 0.003, 0.01, 0.03, 0.1)  # absolute floor as a fraction of the answer scale
DEG_GRID = (0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0)  # absolute, for angles


# --- perturbation models ---------------------------------------------------------------------


def _ulp(v: float, sig: int) -> float:
    return 10.0 ** (math.floor(math.log10(abs(v))) - sig + 1) if v else 0.0


def _sf_error(v: float, sig: int, rng: np.random.Generator) -> float:
    """v with a uniform error of ±0.5 unit in its last kept digit."""
    return v + rng.uniform(-0.5, 0.5) * _ulp(v, sig)


@dataclass
class Model:
    """One honest-student model with its random state (see the module docstring)."""

    name: str
    rng: np.random.Generator
    paper: float = 1.0  # paper m per mechanism m (figure.true_scale)
    omega_max: float = 0.0
    alpha_max: float = 0.0

    @property
    def sig(self) -> int:
        return 4 if self.name == "sf4" else 3

    def angle(self, a: float) -> float:
        if self.name == "graphical":
            return a + math.radians(self.rng.uniform(-READ_DEG, READ_DEG))
        deg = math.degrees(a) % 360.0
        return math.radians(_sf_error(deg, self.sig, self.rng))

    def rate(self, x: float, biggest: float) -> float:
        if self.name == "graphical":
            return x + self.rng.uniform(-1, 1) * READ_MM / FORCE_SCALE_MM * biggest
        return _sf_error(x, self.sig, self.rng)

    def coord(self, x: float) -> float:
        if self.name == "graphical":
            return x + self.rng.uniform(-READ_MM, READ_MM) * 1e-3 / self.paper
        return _sf_error(x, self.sig, self.rng)

    def point(self, p: P) -> P:
        return P(Jet(self.coord(float(p.x.v)), p.x.d, p.x.dd), Jet(self.coord(float(p.y.v)), p.y.d, p.y.dd))

    def linkage(self, link: Linkage) -> Linkage:
        """The student's version of *link*: angles, rates and joint positions as written down."""
        moved: dict[int, P] = {}

        def mv(p: P) -> P:
            if id(p) not in moved:
                moved[id(p)] = self.point(p)
            return moved[id(p)]

        bodies = {}
        for name, b in link.bodies.items():
            ang = b.angle
            if name != link.input_body:
                ang = Jet(
                    self.angle(float(ang.v)),
                    self.rate(float(ang.d), self.omega_max),
                    self.rate(float(ang.dd), self.alpha_max),
                )
            bodies[name] = replace(b, origin=mv(b.origin), angle=ang)
        joints = tuple(replace(j, point=mv(j.point)) for j in link.joints)
        points = {k: mv(p) for k, p in link.points.items()}
        return replace(link, bodies=bodies, joints=joints, points=points)


@contextlib.contextmanager
def _student(model: Model) -> Iterator[None]:
    """Within the block, `pipeline.solve_problem` solves the student's written-down linkage."""
    exact = pipeline.solve

    def solve(link, an, virtual=None):
        return exact(model.linkage(link), an, virtual)

    pipeline.solve = solve
    try:
        yield
    finally:
        pipeline.solve = exact


def _inputs(problem: Problem, values: dict[str, float], model: Model, force_max: float) -> dict[str, float]:
    """The student's version of the given values."""
    out = dict(values)
    for name, v in values.items():
        p = problem.parameters.get(name)
        if p is None or p.expr or not v:
            continue
        if model.name != "graphical":
            out[name] = _sf_error(v, model.sig, model.rng)
            continue
        si = units.si_unit(p.unit)
        if si == units.si_unit("m"):
            out[name] = v + units.convert(model.rng.uniform(-READ_MM, READ_MM) * 1e-3 / model.paper, "m", p.unit)
        elif si == units.si_unit("deg"):
            out[name] = v + units.convert(model.rng.uniform(-READ_DEG, READ_DEG), "deg", p.unit)
        elif si == units.si_unit("N"):
            out[name] = v + units.convert(model.rng.uniform(-1, 1) * READ_MM / FORCE_SCALE_MM * force_max, "N", p.unit)
    return out


def _force_max(case_results: list[dict[str, tuple[float, str]]]) -> float:
    return max(
        (abs(v) for r in case_results for k, (v, u) in r.items() if u == "N" and k.endswith(".mag") and "@" not in k),
        default=1.0,
    )


def _read(model: Model, answers, cases, force_max: float, scale_of: dict[str, float]) -> list[float]:
    """Graphical reading errors added to the answers (see the module docstring)."""
    out = []
    for a in answers:
        kind = answer_kind(a.of, a.unit)
        x = a.value
        u = model.rng.uniform
        if kind == "angle":
            x = (x + u(-READ_DEG, READ_DEG)) % 360.0
        elif kind == "torque":
            case = next(c for c in cases if c.name == a.case)
            link = case.solution.linkage
            drv = case.solution.total.members.get(link.driver.body)
            pin = max((float(np.hypot(*f.vector)) for f in drv.forces), default=0.0) if drv else 0.0
            if pin > 0 and x:
                f_mm = FORCE_SCALE_MM * pin / force_max
                arm_mm = abs(units.to_si(x, a.unit)) / pin * 1e3 * model.paper
                x *= 1 + u(-READ_MM, READ_MM) / f_mm + u(-READ_MM, READ_MM) / max(arm_mm, READ_MM)
        elif kind != "length":
            x += u(-1, 1) * READ_MM / FORCE_SCALE_MM * scale_of.get(units.si_unit(a.unit), abs(x))
        out.append(x)
    return out


def _written(model: Model, x: float, kind: str) -> float:
    x = pipeline.sig_round(x, model.sig)
    return x % 360.0 if kind == "angle" else x


# --- the study -------------------------------------------------------------------------------


@dataclass
class AnswerData:
    """Everything simulated for one answer over the variants of a problem."""

    key: str
    of: str
    unit: str
    kind: str
    exact: np.ndarray  # (V,)
    scale: np.ndarray  # (V,) largest |answer| of the same unit in the variant
    honest: dict[str, np.ndarray]  # model -> (V, K), NaN where the student's solve failed
    mistakes: dict[str, np.ndarray]  # mistake name -> (V,), NaN where it does not apply


@dataclass
class Study:
    problem: Problem
    method: str
    variants: int
    per_variant: int
    answers: dict[str, AnswerData]
    failures: int = 0
    notes: list[str] = field(default_factory=list)


def paper_scale(problem: Problem, variant_: Variant) -> float:
    """Paper length per mechanism length: ``figure.true_scale``, else the largest link at 100 mm."""
    if problem.figure.true_scale:
        return float(problem.figure.true_scale)
    link = variant_.result.cases[0].solution.linkage
    return 0.1 / link.scale


def simulate(
    problem: Problem, n_variants: int = 40, per_variant: int = 30, seed: int = 373, models: tuple[str, ...] = MODELS
) -> Study:
    """Draw variants of *problem* and simulate every honest model and every mistake on each."""
    from gradekit.grading.compare import generic_mistakes
    from gradekit.mistakes import catalogued_mistakes

    randoms = any(p.random for p in problem.parameters.values())
    vs: list[Variant] = []
    s = 0
    while len(vs) < (n_variants if randoms else 1) and s < 4 * n_variants:
        try:
            vs.append(variant(problem, seed=seed * 100003 + s) if randoms else variant(problem))
        except GradekitError:
            pass
        s += 1
    nv = len(vs)
    k = per_variant if randoms else per_variant * n_variants
    keys = [a.key for a in vs[0].result.answers]
    meta = {a.key: a for a in vs[0].result.answers}
    exact = {key: np.full(nv, np.nan) for key in keys}
    scale = {key: np.full(nv, np.nan) for key in keys}
    honest = {key: {m: np.full((nv, k), np.nan) for m in models} for key in keys}
    mist: dict[str, dict[str, np.ndarray]] = {key: {} for key in keys}
    rng = np.random.default_rng(seed)
    failures = 0
    for i, v in enumerate(vs):
        res = v.result
        by_unit: dict[str, float] = {}
        for a in res.answers:
            if a.unit != "deg":
                by_unit[units.si_unit(a.unit)] = max(by_unit.get(units.si_unit(a.unit), 0.0), abs(a.value))
        for a in res.answers:
            exact[a.key][i] = a.value
            scale[a.key][i] = by_unit.get(units.si_unit(a.unit), 360.0)
        results = [c.results for c in res.cases]
        fmax = _force_max(results)
        si_scale: dict[str, float] = {}
        for r in results:
            for key_, (val, u) in r.items():
                if "@" not in key_ and not key_.endswith((".x", ".y")):
                    su = units.si_unit(u) if u != "deg" else "deg"
                    si_scale[su] = max(si_scale.get(su, 0.0), abs(val))
        answer_scale = {
            units.si_unit(a.unit): units.convert(
                si_scale.get(units.si_unit(a.unit), 0.0) or abs(a.value), units.si_unit(a.unit), a.unit
            )
            for a in res.answers
            if a.unit != "deg"
        }
        states = [st for c in res.cases for st in c.solution.states.values()]
        omax = max((abs(st.omega) for st in states), default=0.0)
        amax = max((abs(st.alpha) for st in states), default=0.0)
        for m in models:
            model = Model(m, rng, paper_scale(problem, v), omax, amax)
            for j in range(k):
                try:
                    with _student(model):
                        sr = pipeline.solve_problem(problem, _inputs(problem, v.values, model, fmax))
                except GradekitError:
                    failures += 1
                    continue
                vals = (
                    _read(model, sr.answers, sr.cases, fmax, answer_scale)
                    if m == "graphical"
                    else [a.value for a in sr.answers]
                )
                for a, x in zip(sr.answers, vals, strict=True):
                    honest[a.key][m][i, j] = _written(model, x, answer_kind(a.of, a.unit))
        for key_, ms in catalogued_mistakes(v).items():
            for mk in ms:
                mist[key_].setdefault(mk.name, np.full(nv, np.nan))[i] = mk.value
        for a in res.answers:
            entry = KeyEntry("", problem.id, a.key, float(a.value), a.unit, Tolerance())
            for mk in generic_mistakes(entry):
                if mk.name in mist[a.key] and not math.isnan(mist[a.key][mk.name][i]):
                    continue
                mist[a.key].setdefault(mk.name, np.full(nv, np.nan))[i] = mk.value
    answers = {
        key: AnswerData(
            key,
            meta[key].of,
            meta[key].unit,
            answer_kind(meta[key].of, meta[key].unit),
            exact[key],
            scale[key],
            honest[key],
            mist[key],
        )
        for key in keys
    }
    return Study(problem, problem.method, nv, k, answers, failures)


# --- scoring ---------------------------------------------------------------------------------


def accepts(tol: Tolerance, answer: np.ndarray, value: np.ndarray) -> np.ndarray:
    """Vectorised `Tolerance.accepts` (relative mode): NaN/inf never accepted."""
    band = np.maximum(tol.rel * np.abs(value), tol.abs)
    with np.errstate(invalid="ignore"):
        ok = np.abs(answer - value) <= band * (1 + 1e-12)
    return ok & np.isfinite(answer) & np.isfinite(value)


@dataclass
class Score:
    tolerance: Tolerance
    floor_frac: float
    false_reject: dict[str, float]  # model -> rate
    detection: dict[str, float]  # mistake -> rate
    samples: int

    def worst_detection(self) -> float:
        return min(self.detection.values(), default=1.0)


def evaluate(a: AnswerData, tol: Tolerance, models: tuple[str, ...], floor_frac: float = 0.0) -> Score:
    """False-reject rate per honest model and detection rate per mistake of *tol* on *a*."""
    fr = {}
    n = 0
    for m in models:
        h = a.honest.get(m)
        if h is None:
            continue
        good = np.isfinite(h)
        n = max(n, int(good.sum()))
        ok = accepts(tol, h, a.exact[:, None])
        fr[m] = float((~ok & good).sum() / max(good.sum(), 1))
    det = {}
    for name, vals in a.mistakes.items():
        live = np.isfinite(vals)
        if live.any():
            det[name] = float((~accepts(tol, vals, a.exact) & live).sum() / live.sum())
    return Score(tol, floor_frac, fr, det, n)


def candidates(a: AnswerData) -> Iterator[tuple[Tolerance, float]]:
    """Candidate tolerances, loosest last: relative with an absolute floor (a fraction of the
    median answer scale, rounded to two significant figures); absolute only for angles."""
    if a.kind == "angle":
        for d in DEG_GRID:
            yield Tolerance("relative", 0.0, d), 0.0
        return
    ref = float(np.nanmedian(a.scale)) if np.isfinite(a.scale).any() else 1.0
    for rel in REL_GRID:
        for f in FLOOR_GRID:
            yield Tolerance("relative", rel, pipeline.sig_round(f * ref, 2)), f


def basis(method: str) -> tuple[str, ...]:
    """The honest models a tolerance must accept (issue 7): intermediate values rounded to three
    and to four significant figures, and for graphical problems the drawing at the printed scale."""
    return ("sf3", "sf4", "graphical") if method == "graphical" else ("sf3", "sf4")


def width(a: AnswerData, tol: Tolerance) -> float:
    """Median half-width of the band relative to the answer (angles: degrees)."""
    if a.kind == "angle":
        return tol.abs
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.maximum(tol.rel * np.abs(a.exact), tol.abs) / np.abs(a.exact)
    return float(np.nanmedian(np.where(np.isfinite(w), w, np.nan)))


def choose(a: AnswerData, method: str) -> tuple[Score, bool]:
    """The tightest candidate rejecting < 0.1 % of honest answers (of every basis model), maximising
    the worst mistake detection; and whether it also catches every mistake ≥ 99 %."""
    models = basis(method)
    best: Score | None = None
    for tol, f in candidates(a):
        s = evaluate(a, tol, models, f)
        if max(s.false_reject.values(), default=0.0) >= FALSE_REJECT_MAX:
            continue
        key = (s.worst_detection(), -width(a, tol))
        if best is None or key > (best.worst_detection(), -width(a, best.tolerance)):
            best = s
    if best is None:  # nothing honest enough on the grid: the loosest
        tol, f = list(candidates(a))[-1]
        best = evaluate(a, tol, models, f)
    return best, best.worst_detection() >= DETECT_MIN


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


def variant_band(a: AnswerData, models: tuple[str, ...], k: float = 1.5) -> np.ndarray:
    """Per-variant half-width: *k* × the largest honest error seen on that variant (all models)."""
    worst = np.zeros(len(a.exact))
    for m in models:
        h = a.honest.get(m)
        if h is not None:
            worst = np.maximum(worst, np.nanmax(np.abs(h - a.exact[:, None]), axis=1))
    return k * worst


def evaluate_band(a: AnswerData, band: np.ndarray, models: tuple[str, ...]) -> Score:
    """`evaluate` with a per-variant band instead of a fixed tolerance."""
    fr = {}
    for m in models:
        h = a.honest[m]
        good = np.isfinite(h)
        bad = np.abs(h - a.exact[:, None]) > band[:, None] * (1 + 1e-12)
        fr[m] = float((bad & good).sum() / max(good.sum(), 1))
    det = {}
    for name, vals in a.mistakes.items():
        live = np.isfinite(vals)
        if live.any():
            det[name] = float(((np.abs(vals - a.exact) > band) & live).sum() / live.sum())
    return Score(Tolerance("relative", 0.0, 0.0), 0.0, fr, det, 0)


@dataclass
class Choice:
    """The outcome for one answer: the chosen tolerance and its rates, plus the per-variant fallback."""

    problem: str
    method: str
    key: str
    kind: str
    score: Score
    both: bool
    q999: dict[str, float]  # model -> 99.9 % quantile of the honest relative (angle: abs) error
    per_variant: Score | None = None
    missed: dict[str, float] = field(default_factory=dict)  # mistake -> median relative size when missed


def study_choices(st: Study) -> list[Choice]:
    out = []
    for a in st.answers.values():
        score, both = choose(a, st.method)
        q = {m: float(np.quantile(e, 0.999)) if (e := honest_errors(a, m)).size else math.nan for m in a.honest}
        pv = None
        missed = {}
        if not both:
            pv = evaluate_band(a, np.maximum(variant_band(a, basis(st.method)), 1e-300), basis(st.method))
            for name, rate in score.detection.items():
                if rate < DETECT_MIN:
                    vals = a.mistakes[name]
                    with np.errstate(invalid="ignore", divide="ignore"):
                        rel = np.abs(vals - a.exact) / np.abs(a.exact)
                    missed[name] = float(np.nanmedian(rel))
        out.append(Choice(st.problem.id, st.method, a.key, a.kind, score, both, q, pv, missed))
    return out


def kind_defaults(studies: list[Study]) -> dict[tuple[str, str], Choice]:
    """One tolerance per (method, answer kind) over every answer of that kind: relative with a
    floor of ``floor_frac`` × the answer's median scale (the largest same-unit answer of its
    variant); among the pairs whose pooled false-reject rate is < 0.1 %, the one catching the
    most of its worst mistake, then the smallest relative part."""
    out: dict[tuple[str, str], Choice] = {}
    pools: dict[tuple[str, str], list[AnswerData]] = {}
    for st in studies:
        for a in st.answers.values():
            pools.setdefault((st.method, a.kind), []).append(a)
    for (method, kind), answers in pools.items():
        models = basis(method)
        grid = (
            [(0.0, d, 0.0) for d in DEG_GRID]
            if kind == "angle"
            else [(r, 0.0, f) for r in REL_GRID for f in FLOOR_GRID]
        )
        best = None
        for rel, deg, f in grid:
            n_h = bad = 0
            det: dict[str, list[float]] = {}
            for a in answers:
                ref = float(np.nanmedian(a.scale)) if np.isfinite(a.scale).any() else 1.0
                s = evaluate(a, Tolerance("relative", rel, deg or pipeline.sig_round(f * ref, 2)), models, f)
                for m in models:
                    n = int(np.isfinite(a.honest[m]).sum())
                    n_h += n
                    bad += s.false_reject[m] * n
                for name, r in s.detection.items():
                    det.setdefault(name, []).append(r)
            pooled = Score(
                Tolerance("relative", rel, deg),
                f,
                {"all": bad / max(n_h, 1)},
                {k: float(np.mean(v)) for k, v in det.items()},
                n_h,
            )
            c = Choice("*", method, "*", kind, pooled, pooled.worst_detection() >= DETECT_MIN, {})
            feasible = pooled.false_reject["all"] < FALSE_REJECT_MAX
            rank = (feasible, pooled.worst_detection() if feasible else -pooled.false_reject["all"], -rel - f)
            if best is None or rank > best[0]:
                best = (rank, c)
        if best is not None:
            out[(method, kind)] = best[1]
    return out


__all__ = [
    "MODELS",
    "AnswerData",
    "Choice",
    "Study",
    "accepts",
    "answer_kind",
    "choose",
    "evaluate",
    "evaluate_band",
    "kind_defaults",
    "simulate",
    "study_choices",
    "variant_band",
]
