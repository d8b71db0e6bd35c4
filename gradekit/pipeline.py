"""From a problem and parameter values (one variant, or a batch) to the solved answers.

The batched path (`solve_many`) is the only path: one variant is a batch of one
(`solve_problem`). Refused variants of a batch (cannot be assembled, too ill-conditioned, a
derived value undefined) are masked with their reasons, never raised; one variant raises its
reason as a `GeometryError` with the problem file and field.

``values`` are the numbers a student sees, each in its parameter's unit. Fields of the problem
that name a single parameter take it through its unit; literal numbers and expressions are read in
the problem's default unit for the field's dimension (``units:``). The mechanics core is fed SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.schema import ANGLE_PARAMS, Parameter, Problem, Value, order
from gradekit.errors import ConditioningError, GeometryError, ProblemError
from gradekit.mechanics import forces
from gradekit.mechanics.forces import Solution, Solutions
from gradekit.mechanics.mechanisms import Motion, build_many
from gradekit.mechanics.model import Analysis, Batched, Linkage, Load, MassProps, Refusals

SI = {
    "length": "m",
    "force": "N",
    "mass": "kg",
    "inertia": "kg*m**2",
    "torque": "N*m",
    "angle": "rad",
    "angular_velocity": "rad/s",
    "angular_acceleration": "rad/s**2",
    "acceleration": "m/s**2",
}


def _rows(values: dict, n: int) -> list[dict[str, float]]:
    return [{k: float(v[i]) if np.ndim(v) else float(v) for k, v in values.items()} for i in range(n)]


def fill(problem: Problem, values: dict[str, float]) -> dict[str, float]:
    """Complete *values* with the derived parameters (``expr``), rounded as they are printed."""
    out = dict(values)
    for name in order(problem.parameters):
        p = problem.parameters[name]
        if p.expr and name not in values:
            try:
                v = float(expr.evaluate(p.expr, out))
            except expr.ExprError as exc:
                raise ProblemError(str(exc), path=problem.path, field=f"parameters.{name}.expr") from None
            out[name] = round_display(p, v)
    return out


def fill_many(problem: Problem, values: dict, n: int, bad: Refusals) -> dict[str, np.ndarray]:
    """`fill` for a batch: arrays of *n* values; a variant whose derived value is undefined is refused."""
    out = {k: np.broadcast_to(np.asarray(v, float), (n,)) for k, v in values.items()}
    for name in order(problem.parameters):
        p = problem.parameters[name]
        if not p.expr or name in values:
            continue
        col = np.full(n, np.nan)
        for i, row in enumerate(_rows(out, n)):
            if bad.mask[i]:
                continue
            try:
                col[i] = round_display(p, float(expr.evaluate(p.expr, row)))
            except (expr.ExprError, ValueError, ZeroDivisionError, OverflowError) as exc:
                bad.add(np.arange(n) == i, lambda _i, f=f"parameters.{name}.expr", e=str(exc): f"derived: {f}: {e}")
        out[name] = col
    return out


def round_display(p: Parameter, v: float) -> float:
    """Round *v* the way parameter *p* is printed (its decimals or significant figures)."""
    if p.decimals is not None:
        return round(v, p.decimals)
    if p.sigfigs:
        return sig_round(v, p.sigfigs)
    if p.step:
        return round(round(v / p.step) * p.step, 10)
    return sig_round(v, 6)


def sig_round(v: float, sig: int) -> float:
    if v == 0 or not math.isfinite(v):
        return v
    return round(v, sig - 1 - int(math.floor(math.log10(abs(v)))))


def _evaluate(text: str, values: dict, n: int):
    """An expression over (batched) parameter values: vectorised when numpy can, else per variant."""
    try:
        with np.errstate(all="ignore"):
            out = expr.evaluate(text, values)
        if np.ndim(out) in (0, 1) and np.isfinite(out).all():
            return out
    except Exception:  # math functions and comparisons take scalars only: evaluate per variant
        pass
    if n == 1 or not any(np.ndim(v) for v in values.values()):
        return float(expr.evaluate(text, {k: float(np.ravel(v)[0]) for k, v in values.items()}))
    return np.array([float(expr.evaluate(text, row)) for row in _rows(values, n)])


@dataclass
class Context:
    """Resolves problem fields to SI numbers for one variant, or for a batch of *n* (arrays)."""

    problem: Problem
    values: dict
    n: int = 1

    def si(self, v: Value | None, dim: str, where: str, default: float = 0.0):
        if v is None:
            return default
        pr = self.problem
        if isinstance(v, str) and v in pr.parameters:
            try:
                return units.convert(self.values[v], pr.parameters[v].unit, SI[dim])
            except Exception as exc:
                raise ProblemError(
                    f"expected a {dim.replace('_', ' ')} unit for parameter {v!r}, got "
                    f"{pr.parameters[v].unit!r} ({exc})",
                    path=pr.path,
                    field=where,
                ) from None
        try:
            num = float(v) if not isinstance(v, str) else _evaluate(v, self.values, self.n)
        except expr.ExprError as exc:
            raise ProblemError(str(exc), path=pr.path, field=where) from None
        return units.convert(num, pr.units[dim], SI[dim])


def length_formatter(problem: Problem):
    unit = problem.units["length"]
    k = units.factor("m", unit)
    return lambda x: f"{x * k:.4g} {units.pretty(unit)}"


def build_linkage(problem: Problem, values: dict, unit_speed: bool = False, n: int = 1) -> Linkage:
    """The mechanism of *problem* at *values* (floats, or arrays of *n*), with its exact kinematics.

    Variants that cannot be assembled are refused in the linkage's ``refused`` (never raised).
    """
    ctx = Context(problem, values, n)
    geo = {
        k: ctx.si(v, "angle" if k in ANGLE_PARAMS else "length", f"mechanism.geometry.{k}")
        for k, v in problem.geometry.items()
        if k != "ram_branch"
    }
    if "ram_branch" in problem.geometry:
        geo["ram_branch"] = 1 if float(problem.geometry["ram_branch"]) >= 0 else -1
    theta = ctx.si(problem.inputs["theta"], "angle", "mechanism.input.theta")
    omega = ctx.si(problem.inputs.get("omega"), "angular_velocity", "mechanism.input.omega")
    alpha = ctx.si(problem.inputs.get("alpha"), "angular_acceleration", "mechanism.input.alpha")
    if problem.analysis == "static" or unit_speed:
        omega, alpha = 1.0, 0.0  # virtual motion: velocity ratios for the virtual-work check
    return build_many(
        problem.kind,
        geo,
        Motion(theta, omega, alpha),
        problem.branch,
        length_formatter(problem),
        problem.driver,
        n=n,
    )


def build_analysis(problem: Problem, values: dict, n: int = 1) -> Analysis:
    ctx = Context(problem, values, n)
    loads = []
    for i, ld in enumerate(problem.loads):
        w = f"loads[{i}]"
        rel = ld.relative_angle
        if ld.magnitude is not None:
            mag = ctx.si(ld.magnitude, "force", f"{w}.magnitude")
            ang = ctx.si(ld.angle, "angle", f"{w}.angle")
            force = (mag, ang) if rel else (mag * np.cos(ang), mag * np.sin(ang))
        else:
            force = (ctx.si(ld.fx, "force", f"{w}.fx"), ctx.si(ld.fy, "force", f"{w}.fy"))
            rel = False
        loads.append(
            Load(
                ld.name,
                ld.body,
                force,
                ctx.si(ld.torque, "torque", f"{w}.torque"),
                ld.at,
                ctx.si(ld.along, "length", f"{w}.along"),
                ctx.si(ld.across, "length", f"{w}.across"),
                rel,
            )
        )
    gravity = None
    if problem.gravity is not None:
        g = ctx.si(problem.gravity["g"], "acceleration", "gravity.g")
        a = ctx.si(problem.gravity.get("angle", -90.0), "angle", "gravity.angle")
        gravity = (g * np.cos(a), g * np.sin(a))
    g_w = (
        ctx.si(problem.weight_g, "acceleration", "weight_g")
        if problem.weight_g is not None
        else np.hypot(*gravity)
        if gravity
        else 9.80665
    )
    mass = {}
    for m in problem.mass:
        w = f"mass.{m.body}"
        kg = (
            ctx.si(m.mass, "mass", f"{w}.mass")
            if m.mass is not None
            else ctx.si(m.weight, "force", f"{w}.weight") / g_w
        )
        mass[m.body] = MassProps(
            kg,
            ctx.si(m.inertia, "inertia", f"{w}.inertia"),
            m.at,
            ctx.si(m.along, "length", f"{w}.along"),
            ctx.si(m.across, "length", f"{w}.across"),
        )
    return Analysis(problem.analysis == "dynamic", gravity, mass, tuple(loads), max_condition=1e7)


@dataclass
class CaseResult:
    """The solution of one case (position) of a problem, with its flat named results in SI."""

    name: str | None
    values: dict[str, float]
    solution: Solution
    results: dict[str, tuple[float, str]] = field(default_factory=dict)


class Answers(list):
    """The answers of a variant in the problem's order; ``answers["T"]`` also finds one by key."""

    def __getitem__(self, k):
        if isinstance(k, str):
            for a in self:
                if a.key == k:
                    return a
            raise KeyError(k)
        return super().__getitem__(k)


@dataclass
class Answer:
    key: str
    value: float
    unit: str
    description: str
    sign: str
    points: float
    tolerance: object
    of: str
    case: str | None
    scale: float = 0.0  # the variant's largest answer of the same dimension (for tolerance floors)
    base_key: str = ""  # the problem's answer key (``key`` carries a case suffix for multi-case answers)


@dataclass
class Result:
    """Everything `gradekit solve` reports for one variant."""

    problem: Problem
    values: dict[str, float]
    cases: list[CaseResult]
    answers: Answers

    @property
    def virtual_work_residual(self) -> float:
        return max(c.solution.virtual_work_residual for c in self.cases)

    @property
    def condition_number(self) -> float:
        return max(c.solution.condition_number for c in self.cases)

    @property
    def transmission_angle(self) -> float:
        return min(c.solution.linkage.transmission for c in self.cases)

    @property
    def checks(self) -> dict[str, float]:
        """The cross-checks of the solve: virtual-work residual, condition number, transmission angle."""
        return {
            "virtual_work_residual": self.virtual_work_residual,
            "condition_number": self.condition_number,
            "transmission_angle": self.transmission_angle,
        }


def _group_label(problem: Problem, group: str) -> str:
    if group.startswith("inertia:"):
        return f"inertia[{problem.label(group.split(':', 1)[1])}]"
    return group


class Results(Mapping):
    """Named results of a batch, ``name -> (array over variants, SI unit)``, each computed on first use.

    A mechanism reports dozens of quantities (every force in every superposition part, every
    point's velocity…) and a problem asks for a few: those are the only ones computed.
    """

    def __init__(self) -> None:
        self._items: dict[str, object] = {}

    def put(self, name: str, make) -> None:
        """Register *make* (a callable returning (values, unit)) or a computed (values, unit) pair."""
        self._items[name] = make

    def __getitem__(self, name: str) -> tuple[np.ndarray, str]:
        item = self._items[name]
        if callable(item):
            item = self._items[name] = item()
        return item

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self):
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def setdefault(self, name: str, value):
        if name not in self._items:
            self._items[name] = value
        return self[name]

    def row(self, i: int) -> RowResults:
        return RowResults(self, i)


class RowResults(Mapping):
    """One variant's view of `Results`: ``name -> (float, SI unit)``."""

    def __init__(self, parent: Results, i: int) -> None:
        self._parent, self._i = parent, i

    def __getitem__(self, name: str) -> tuple[float, str]:
        values, unit = self._parent[name]
        return float(values[self._i]), unit

    def __contains__(self, name: object) -> bool:
        return name in self._parent

    def __iter__(self):
        return iter(self._parent)

    def __len__(self) -> int:
        return len(self._parent)

    def setdefault(self, name: str, value):
        if name not in self._parent:
            self._parent.put(name, (np.full(self._i + 1, value[0]), value[1]))
        return self[name]


def flat_results(problem: Problem, sol: Solutions) -> Results:
    """Name every reported quantity of every variant (see ``of:`` in problem_bank/README.md); SI."""
    link = sol.linkage
    lab = problem.label
    n = sol.n
    out = Results()

    def arr(x) -> np.ndarray:
        return np.broadcast_to(np.asarray(x, float), (n,))

    def vector(name: str, x, y, unit: str) -> None:
        def xy():
            return arr(x() if callable(x) else x), arr(y() if callable(y) else y)

        out.put(name + ".x", lambda: (xy()[0], unit))
        out.put(name + ".y", lambda: (xy()[1], unit))
        out.put(name + ".mag", lambda: (np.hypot(*xy()), unit))
        out.put(name + ".angle", lambda: (np.degrees(np.arctan2(xy()[1], xy()[0])) % 360.0, "deg"))
        out.put(name, lambda: out[name + ".mag"])

    drv_unit = "N*m" if link.driver.kind == "torque" else "N"
    out.put("driver", (sol.driver, drv_unit))
    out.put("transmission", (arr(link.transmission), "deg"))
    groups = {None: sol.total, **{g: sol.x[:, :, k] for k, g in enumerate(sol.group_names)}}
    for gname, x in groups.items():
        suffix = "" if gname is None else "@" + _group_label(problem, gname)
        if gname is not None:
            out.put("driver" + suffix, (x[:, -1], drv_unit))
        for j in link.joints:
            u = sol.joint(j.name, x)
            if hasattr(j, "axis"):
                n_, c = u[:, 0], u[:, 1]
                ax = arr(j.axis.v)

                def fx(n_=n_, ax=ax):
                    return n_ * -np.sin(ax)

                def fy(n_=n_, ax=ax):
                    return n_ * np.cos(ax)

                a, b = j.guide, j.block
                out.put(f"M[{lab(a)},{lab(b)}]{suffix}", (c, "N*m"))
                out.put(f"M[{lab(b)},{lab(a)}]{suffix}", lambda c=c: (-c, "N*m"))
            else:
                fx, fy, a, b = u[:, 0], u[:, 1], j.a, j.b
            vector(f"F[{lab(a)},{lab(b)}]{suffix}", fx, fy, "N")
            vector(f"F[{lab(b)},{lab(a)}]{suffix}", _neg(fx), _neg(fy), "N")
    for name, st in sol.states.items():
        L = lab(name)
        g = np.broadcast_to(st.a_g, (n, 2))
        v = np.broadcast_to(st.v_g, (n, 2))
        out.put(f"theta[{L}]", lambda st=st: (np.degrees(arr(st.angle)) % 360.0, "deg"))
        out.put(f"omega[{L}]", (arr(st.omega), "rad/s"))
        out.put(f"alpha[{L}]", (arr(st.alpha), "rad/s**2"))
        vector(f"aG[{L}]", g[:, 0], g[:, 1], "m/s**2")
        vector(f"vG[{L}]", v[:, 0], v[:, 1], "m/s")

        def fi(k, st=st):
            return lambda: np.broadcast_to(st.inertia_force, (n, 2))[:, k]

        vector(f"Fi[{L}]", fi(0), fi(1), "N")
        out.put(f"Ci[{L}]", lambda st=st: (arr(st.inertia_couple), "N*m"))
        out.put(f"h[{L}]", lambda st=st: (np.nan_to_num(arr(st.offset), posinf=0.0, neginf=0.0), "m"))
    for pname, pt in link.points.items():
        P = problem.point(pname)
        vector(f"v[{P}]", pt.x.d, pt.y.d, "m/s")
        vector(f"a[{P}]", pt.x.dd, pt.y.dd, "m/s**2")
    return out


def _neg(x):
    return (lambda: -x()) if callable(x) else -x


@dataclass
class CaseBatch:
    """One case (position) of a problem solved for every variant of a batch."""

    name: str | None
    values: dict[str, np.ndarray]
    solutions: Solutions
    results: Results


@dataclass
class AnswerBatch:
    """One answer of every variant: values (in the answer's unit) and the variant's scale."""

    key: str
    value: np.ndarray
    unit: str
    spec: object
    case: str | None
    scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def band(self) -> np.ndarray:
        """Half-width of each variant's acceptance band (its tolerance with the floor resolved)."""
        return self.spec.tolerance.bands(self.value, self.scale)


@dataclass
class ResultBatch(Batched):
    """A batch of variants of one problem, solved together.

    ``answers[key]`` is an array of every variant's value in the answer's unit; ``ok`` masks the
    refused variants, ``reason(i)`` says why one was refused. ``take(i)`` is one variant's `Result`.
    """

    problem: Problem
    values: dict[str, np.ndarray]
    cases: list[CaseBatch]
    answer_list: list[AnswerBatch]
    refused: Refusals

    @property
    def answers(self) -> dict[str, np.ndarray]:
        return {a.key: a.value for a in self.answer_list}

    @property
    def units(self) -> dict[str, str]:
        return {a.key: a.unit for a in self.answer_list}

    def reason(self, i: int) -> str:
        return self.refused.reason(i)

    @property
    def virtual_work_residual(self) -> np.ndarray:
        return np.maximum.reduce([c.solutions.virtual_work_residual for c in self.cases])

    @property
    def condition_number(self) -> np.ndarray:
        return np.maximum.reduce([c.solutions.condition_number for c in self.cases])

    def condition_above(self, limit: float) -> np.ndarray:
        """Where any case's condition number exceeds *limit* (an SVD only where bounds cannot tell)."""
        return np.logical_or.reduce([c.solutions.conditioning.above(limit) for c in self.cases])

    @property
    def transmission_angle(self) -> np.ndarray:
        return np.minimum.reduce([np.broadcast_to(c.solutions.linkage.transmission, (self.n,)) for c in self.cases])

    def take(self, i: int) -> Result:
        """Variant *i* as a `Result`; raises its `GeometryError` when it was refused."""
        pr = self.problem
        if self.refused.mask[i]:
            ill = any(c.solutions.ill_conditioned[i] for c in self.cases)
            cls = ConditioningError if ill else GeometryError
            raise cls(f"{pr.id}: {self.reason(i)}", path=pr.path, field="mechanism")
        cases = [
            CaseResult(
                c.name,
                {k: float(v[i]) for k, v in c.values.items()},
                c.solutions.at(i),
                c.results.row(i),
            )
            for c in self.cases
        ]
        answers = Answers(
            Answer(
                a.key,
                float(a.value[i]),
                a.unit,
                a.spec.description,
                a.spec.sign,
                a.spec.points,
                a.spec.tolerance.resolve(float(a.scale[i])),
                a.spec.of,
                a.case,
                float(a.scale[i]),
                base_key=a.spec.key,
            )
            for a in self.answer_list
        )
        return Result(pr, {k: float(v[i]) for k, v in self.values.items()}, cases, answers)


def _solve_case(problem: Problem, values: dict, n: int, name: str | None, bad: Refusals) -> CaseBatch:
    link = build_linkage(problem, values, n=n)
    link.refused.mask |= bad.mask  # variants refused before the build stay refused, with their reason
    link.refused._checks[:0] = bad._checks
    speed = np.broadcast_to(np.asarray(link.bodies[link.input_body].angle.d, float), (n,))
    virtual = None if speed.all() else build_linkage(problem, values, True, n)
    sols = forces.solve_many(link, build_analysis(problem, values, n), virtual)
    return CaseBatch(name, values, sols, flat_results(problem, sols))


def solve_many(problem: Problem, values: dict, n: int | None = None) -> ResultBatch:
    """Solve every case of *problem* for a batch of variants.

    Args:
        problem: the problem.
        values: each non-derived parameter's values (arrays of one entry per variant, or floats
            shared by all), in the parameter's unit, as the students see them.
        n: the batch size (from the arrays when omitted).
    """
    if n is None:
        n = max((np.size(v) for v in values.values()), default=1)
    bad = Refusals(n)
    full = fill_many(problem, values, n, bad)
    if problem.cases:
        cases = [
            _solve_case(problem, fill_many(problem, {**values, **over}, n, bad), n, name, bad)
            for name, over in problem.cases.items()
        ]
    else:
        cases = [_solve_case(problem, full, n, None, bad)]
    refused = bad.copy()
    for c in cases:
        refused.mask |= c.solutions.refused.mask
        refused._checks += c.solutions.refused._checks
    answers = []
    for spec in problem.answers:
        for case in cases:
            if spec.case is not None and spec.case != case.name:
                continue
            key = spec.key if (spec.case is not None or case.name is None) else f"{spec.key}_{case.name}"
            if spec.of.startswith("param["):
                pname = spec.of[6:-1]
                case.results.setdefault(spec.of, (case.values[pname], problem.parameters[pname].unit))
            if spec.of not in case.results:
                raise ProblemError(
                    f"expected a result this mechanism reports (e.g. "
                    f"{', '.join(sorted(k for k in case.results if '.' not in k)[:8])}), "
                    f"got {spec.of!r}",
                    path=problem.path,
                    field=f"answers.{spec.key}.of",
                )
            si_value, si_unit = case.results[spec.of]
            try:
                value = (
                    units.convert(si_value, si_unit, spec.unit) if si_unit != "deg" or spec.unit != "deg" else si_value
                )
            except Exception:
                raise ProblemError(
                    f"expected a unit of the same kind as {si_unit}, got {spec.unit!r}",
                    path=problem.path,
                    field=f"answers.{spec.key}.unit",
                ) from None
            answers.append(AnswerBatch(key, np.asarray(value, float), spec.unit, spec, case.name))
    # Floors are fractions of the variant's scale: its largest answer of the same dimension,
    # compared in SI (an answer in kN beside one in N), expressed in each answer's own unit.
    by_dim: dict[str, list[AnswerBatch]] = {}
    for a in answers:
        by_dim.setdefault(units.si_unit(a.unit), []).append(a)
    for dim, group in by_dim.items():
        if len({a.unit for a in group}) == 1:
            top = np.maximum.reduce([np.abs(a.value) for a in group])
            for a in group:
                a.scale = top
        else:
            top = np.maximum.reduce([np.abs(units.to_si(a.value, a.unit)) for a in group])
            for a in group:
                a.scale = top * units.factor(dim, a.unit)
    return ResultBatch(problem, full, cases, answers, refused)


def solve_problem(problem: Problem, values: dict[str, float]) -> Result:
    """Solve every case of *problem* for one student's *values* and express the answers.

    Raises:
        GeometryError: the variant cannot be assembled or is too near a singular position.
        ProblemError: a derived value is undefined for these values.
    """
    batch = solve_many(problem, values, 1)
    if batch.refused.mask[0]:
        reason = batch.reason(0)
        if reason.startswith("derived: "):
            fld, _, msg = reason[len("derived: ") :].partition(": ")
            raise ProblemError(msg, path=problem.path, field=fld)
    return batch.take(0)


def published_values(problem: Problem) -> dict[str, float]:
    """The fixed ('as published') values of every non-derived parameter."""
    return {n: p.value for n, p in problem.parameters.items() if not p.expr and p.value is not None}


__all__ = ["Result", "ResultBatch", "solve_problem", "solve_many", "published_values", "fill", "build_linkage"]
