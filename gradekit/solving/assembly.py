"""Assembly phase: a problem and one variant's values (or a batch's arrays) → the mechanism and its loads.

Fields of the problem that name a single parameter take it through its unit; literal numbers and
expressions are read in the problem's default unit for the field's dimension (``units:``). The
mechanics core is fed SI and never sees a problem file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.model import Problem, Value
from gradekit.errors import ProblemError
from gradekit.mechanics.mechanisms import KINDS, Motion, build_many
from gradekit.mechanics.model import Analysis, Linkage, Load, MassProps, MotionLoad, Spot

SI = {
    "stiffness": "N/m",
    "damping": "N*s/m",
    "rotary_damping": "N*m*s",
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


def _evaluate(text: str, values: dict):
    """An expression over (batched) parameter values: a float, or an array of one per variant.

    Raises:
        ExprError: the expression has no value for some variant (the first such variant's reason).
    """
    rows = expr.evaluate_rows(text, values)
    if rows.undefined.any():
        raise expr.ExprError(rows.reason(int(np.flatnonzero(rows.undefined.reshape(-1))[0])))
    return float(rows.value) if np.ndim(rows.value) == 0 else rows.value


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
                    line=pr.line(where),
                ) from None
        try:
            num = float(v) if not isinstance(v, str) else _evaluate(v, self.values)
        except expr.ExprError as exc:
            raise ProblemError(str(exc), path=pr.path, field=where, line=pr.line(where)) from None
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
    kind = KINDS[problem.kind]
    geo = {
        k: ctx.si(v, "angle" if k in kind.angles else "length", f"mechanism.geometry.{k}")
        for k, v in problem.geometry.items()
        if k not in kind.signs
    }
    for k in kind.signs:
        if k in problem.geometry:
            geo[k] = 1 if float(problem.geometry[k]) >= 0 else -1
    theta = ctx.si(problem.inputs["theta"], "angle", "mechanism.input.theta")
    omega = ctx.si(problem.inputs.get("omega"), "angular_velocity", "mechanism.input.omega")
    alpha = ctx.si(problem.inputs.get("alpha"), "angular_acceleration", "mechanism.input.alpha")
    moving_loads = any(ld.type != "force" for ld in problem.loads)
    if (problem.analysis == "static" and not moving_loads) or unit_speed:
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
    spots = {
        k: Spot(
            d.body, d.at, ctx.si(d.along, "length", f"mechanism.points.{d.name}.along"),
            ctx.si(d.across, "length", f"mechanism.points.{d.name}.perp"),
        )
        for k, d in problem.defined_points.items()
    }

    def spot(body: str, at: str, along=0.0, across=0.0) -> Spot:
        """A point on *body* from point *at* (an author-defined point resolved to a mechanism point)."""
        if at in spots:
            s = spots[at]
            return Spot(body, s.at, s.along + along, s.across + across)
        return Spot(body, at, along, across)

    motion = []
    for i, ld in enumerate(problem.loads):
        w = f"loads[{i}]"
        if ld.type == "force":
            continue
        dim = {"damper": "damping", "spring": "stiffness", "rotary_damper": "rotary_damping",
               "resistance": "force"}[ld.type]
        key = {"damper": "c", "spring": "k", "rotary_damper": "c", "resistance": "magnitude"}[ld.type]
        coeff = ctx.si(ld.coefficient if ld.type != "resistance" else ld.magnitude, dim, f"{w}.{key}")
        if ld.type == "rotary_damper":
            motion.append(MotionLoad(ld.name, ld.type, coeff, body=ld.body, other=ld.relative_to))
        elif ld.type == "resistance":
            motion.append(MotionLoad(ld.name, ld.type, coeff, (spot(ld.body, ld.at),)))
        else:
            ends = tuple(spot(b, p) for b, p in zip(ld.bodies, ld.between, strict=True))
            free = ctx.si(ld.free_length, "length", f"{w}.free_length")
            motion.append(MotionLoad(ld.name, ld.type, coeff, ends, free))
    for i, ld in enumerate(problem.loads):
        w = f"loads[{i}]"
        if ld.type != "force":
            continue
        rel = ld.relative_angle
        if ld.magnitude is not None:
            mag = ctx.si(ld.magnitude, "force", f"{w}.magnitude")
            ang = ctx.si(ld.angle, "angle", f"{w}.angle")
            force = (mag, ang) if rel else (mag * np.cos(ang), mag * np.sin(ang))
        else:
            force = (ctx.si(ld.fx, "force", f"{w}.fx"), ctx.si(ld.fy, "force", f"{w}.fy"))
            rel = False
        where = spot(ld.body, ld.at, ctx.si(ld.along, "length", f"{w}.along"),
                     ctx.si(ld.across, "length", f"{w}.across"))
        loads.append(
            Load(
                ld.name,
                ld.body,
                force,
                ctx.si(ld.torque, "torque", f"{w}.torque"),
                where.at,
                where.along,
                where.across,
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
        g_at = spot(m.body, m.at, ctx.si(m.along, "length", f"{w}.along"), ctx.si(m.across, "length", f"{w}.across"))
        mass[m.body] = MassProps(kg, ctx.si(m.inertia, "inertia", f"{w}.inertia"), g_at.at, g_at.along, g_at.across)
    return Analysis(
        problem.analysis == "dynamic", gravity, mass, tuple(loads), max_condition=1e7, motion_loads=tuple(motion),
        points=spots,
    )
