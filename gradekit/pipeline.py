"""From a problem and one set of parameter values to the solved answers.

``values`` are the numbers a student sees, each in its parameter's unit. Fields of the problem
that name a single parameter take it through its unit; literal numbers and expressions are read in
the problem's default unit for the field's dimension (``units:``). The mechanics core is fed SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.schema import ANGLE_PARAMS, Parameter, Problem, Value, order
from gradekit.errors import GeometryError, ProblemError
from gradekit.mechanics.forces import Solution, solve
from gradekit.mechanics.mechanisms import Motion, build
from gradekit.mechanics.model import Analysis, Linkage, Load, MassProps

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


@dataclass
class Context:
    """Resolves problem fields to SI numbers for one variant."""

    problem: Problem
    values: dict[str, float]

    def si(self, v: Value | None, dim: str, where: str, default: float = 0.0) -> float:
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
            num = float(v) if not isinstance(v, str) else float(expr.evaluate(v, self.values))
        except expr.ExprError as exc:
            raise ProblemError(str(exc), path=pr.path, field=where) from None
        return units.convert(num, pr.units[dim], SI[dim])


def length_formatter(problem: Problem):
    unit = problem.units["length"]
    k = units.factor("m", unit)
    return lambda x: f"{x * k:.4g} {units.pretty(unit)}"


def build_linkage(problem: Problem, values: dict[str, float], unit_speed: bool = False) -> Linkage:
    """The mechanism of *problem* at *values*, with its exact kinematics."""
    ctx = Context(problem, values)
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
    try:
        return build(
            problem.kind, geo, Motion(theta, omega, alpha), problem.branch, length_formatter(problem), problem.driver
        )
    except GeometryError as exc:
        raise GeometryError(f"{problem.id}: {exc.detail}", path=problem.path, field="mechanism") from None


def build_analysis(problem: Problem, values: dict[str, float]) -> Analysis:
    ctx = Context(problem, values)
    loads = []
    for i, ld in enumerate(problem.loads):
        w = f"loads[{i}]"
        rel = ld.relative_angle
        if ld.magnitude is not None:
            mag = ctx.si(ld.magnitude, "force", f"{w}.magnitude")
            ang = ctx.si(ld.angle, "angle", f"{w}.angle")
            force = (mag, ang) if rel else (mag * math.cos(ang), mag * math.sin(ang))
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
        gravity = (g * math.cos(a), g * math.sin(a))
    g_w = (
        ctx.si(problem.weight_g, "acceleration", "weight_g")
        if problem.weight_g is not None
        else math.hypot(*gravity)
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
    answers: list[Answer]

    @property
    def virtual_work_residual(self) -> float:
        return max(c.solution.virtual_work_residual for c in self.cases)

    @property
    def condition_number(self) -> float:
        return max(c.solution.condition_number for c in self.cases)

    @property
    def transmission_angle(self) -> float:
        return min(c.solution.linkage.transmission for c in self.cases)


def flat_results(problem: Problem, sol: Solution) -> dict[str, tuple[float, str]]:
    """Name every reported quantity (see the ``of:`` field in problem_bank/README.md); SI units."""
    link = sol.linkage
    lab = problem.label
    out: dict[str, tuple[float, str]] = {}

    def vector(name: str, v: np.ndarray, unit: str) -> None:
        out[name + ".x"] = (float(v[0]), unit)
        out[name + ".y"] = (float(v[1]), unit)
        out[name + ".mag"] = (float(np.hypot(*v)), unit)
        out[name + ".angle"] = (math.degrees(math.atan2(v[1], v[0])) % 360.0, "deg")
        out[name] = out[name + ".mag"]

    drv_unit = "N*m" if link.driver.kind == "torque" else "N"
    out["driver"] = (sol.driver, drv_unit)
    out["transmission"] = (link.transmission, "deg")
    groups = {None: sol.total, **sol.groups}
    for gname, res in groups.items():
        suffix = "" if gname is None else "@" + _group_label(problem, gname)
        if gname is not None:
            out["driver" + suffix] = (res.driver, drv_unit)
        for j in link.joints:
            if hasattr(j, "axis"):
                n_, c = res.joints[j.name]
                vec = n_ * np.array([-math.sin(j.axis.v), math.cos(j.axis.v)])
                a, b = j.guide, j.block
                out[f"M[{lab(a)},{lab(b)}]{suffix}"] = (float(c), "N*m")
                out[f"M[{lab(b)},{lab(a)}]{suffix}"] = (-float(c), "N*m")
            else:
                vec, a, b = res.joints[j.name], j.a, j.b
            vector(f"F[{lab(a)},{lab(b)}]{suffix}", vec, "N")
            vector(f"F[{lab(b)},{lab(a)}]{suffix}", -vec, "N")
    for name, st in sol.states.items():
        L = lab(name)
        out[f"theta[{L}]"] = (math.degrees(st.angle) % 360.0, "deg")
        out[f"omega[{L}]"] = (st.omega, "rad/s")
        out[f"alpha[{L}]"] = (st.alpha, "rad/s**2")
        vector(f"aG[{L}]", st.a_g, "m/s**2")
        vector(f"vG[{L}]", st.v_g, "m/s")
        vector(f"Fi[{L}]", st.inertia_force, "N")
        out[f"Ci[{L}]"] = (st.inertia_couple, "N*m")
        out[f"h[{L}]"] = (st.offset if math.isfinite(st.offset) else 0.0, "m")
    for pname, pt in link.points.items():
        P = problem.point(pname)
        vector(f"v[{P}]", pt.vel(), "m/s")
        vector(f"a[{P}]", pt.acc(), "m/s**2")
    return out


def _group_label(problem: Problem, group: str) -> str:
    if group.startswith("inertia:"):
        return f"inertia[{problem.label(group.split(':', 1)[1])}]"
    return group


def solve_case(problem: Problem, values: dict[str, float], name: str | None = None) -> CaseResult:
    link = build_linkage(problem, values)
    virtual = link if float(link.bodies[link.input_body].angle.d) else build_linkage(problem, values, True)
    sol = solve(link, build_analysis(problem, values), virtual)
    return CaseResult(name, values, sol, flat_results(problem, sol))


def solve_problem(problem: Problem, values: dict[str, float]) -> Result:
    """Solve every case of *problem* for one student's *values* and express the answers."""
    full = fill(problem, values)
    cases = (
        [solve_case(problem, fill(problem, {**values, **over}), name) for name, over in problem.cases.items()]
        if problem.cases
        else [solve_case(problem, full)]
    )
    answers = []
    for spec in problem.answers:
        for case in cases:
            if spec.case is not None and spec.case != case.name:
                continue
            key = spec.key if (spec.case is not None or case.name is None) else f"{spec.key}_{case.name}"
            if spec.of.startswith("param["):
                name = spec.of[6:-1]
                case.results.setdefault(spec.of, (case.values[name], problem.parameters[name].unit))
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
            answers.append(
                Answer(
                    key,
                    value,
                    spec.unit,
                    spec.description,
                    spec.sign,
                    spec.points,
                    spec.tolerance,
                    spec.of,
                    case.name,
                    base_key=spec.key,
                )
            )
    # Floors are fractions of the variant's scale: its largest answer of the same dimension.
    scale: dict[str, float] = {}
    for a in answers:
        dim = units.si_unit(a.unit)
        scale[dim] = max(scale.get(dim, 0.0), abs(a.value))
    for a in answers:
        a.scale = scale[units.si_unit(a.unit)]
        a.tolerance = a.tolerance.resolve(a.scale)
    return Result(problem, full, cases, answers)


def published_values(problem: Problem) -> dict[str, float]:
    """The fixed ('as published') values of every non-derived parameter."""
    return {n: p.value for n, p in problem.parameters.items() if not p.expr and p.value is not None}


__all__ = ["Result", "solve_problem", "published_values", "fill", "build_linkage"]
