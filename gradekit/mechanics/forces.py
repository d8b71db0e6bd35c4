"""Static and dynamic (d'Alembert) force analysis of one mechanism position.

Every moving body contributes three equilibrium equations (forces in x and y, moments about the
body's origin) including inertia forces −m·a_G and couples −I_G·α. The unknowns are the pin
forces, each slider's normal force and couple, and the driving torque or force. The loads of each
superposition group (each named load, gravity, each body's inertia) form one right-hand side, so
the solution for every group and their sum come from one factorisation.

The driving torque is cross-checked on every solve by virtual work (power balance including
inertia terms), which uses only the kinematics, not the matrix.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gradekit.errors import ConditioningError
from gradekit.mechanics.jet import P, along
from gradekit.mechanics.model import GROUND, Analysis, Linkage, Load, Prismatic

VW_LIMIT = 1e-9


def _cross(r: np.ndarray, f: np.ndarray) -> float:
    return float(r[0] * f[1] - r[1] * f[0])


@dataclass(frozen=True)
class BodyState:
    """Kinematics and inertia of one body; vectors are world (x, y) arrays in SI."""

    angle: float
    omega: float
    alpha: float
    g: np.ndarray
    v_g: np.ndarray
    a_g: np.ndarray
    mass: float
    inertia: float

    @property
    def inertia_force(self) -> np.ndarray:
        return -self.mass * self.a_g

    @property
    def inertia_couple(self) -> float:
        return -self.inertia * self.alpha

    @property
    def offset(self) -> float:
        """h = I·α / (m·|a_G|): distance of the equivalent offset inertia force from G."""
        f = float(np.hypot(*self.inertia_force))
        return abs(self.inertia_couple) / f if f > 0 else math.inf if self.inertia_couple else 0.0


@dataclass(frozen=True)
class AppliedForce:
    """A force acting on *body* with its line of action through *point* (graphical data)."""

    name: str
    body: str
    point: np.ndarray
    vector: np.ndarray
    kind: str  # pin | normal | load | gravity | inertia | driver


@dataclass(frozen=True)
class Member:
    """What acts on one body, for the graphical method.

    ``forces`` are single forces (an inertia force and couple are merged into the equivalent
    offset inertia force; a slider's normal force and couple into one offset normal force);
    ``couples`` are what remain (driving torque, pure external torques). ``kind`` is
    ``two-force``, ``three-force``, ``two-forces-and-couple`` or ``general``; ``concurrency`` is
    the point where the lines of action of a three-force member meet (None if parallel);
    ``polygon`` the vertices of its force polygon, head to tail from the origin.
    """

    body: str
    forces: tuple[AppliedForce, ...]
    couples: tuple[tuple[str, float], ...]
    kind: str
    concurrency: np.ndarray | None
    polygon: np.ndarray


@dataclass(frozen=True)
class GroupResult:
    """Driver value and joint reactions due to one superposition group (or the total)."""

    driver: float
    joints: dict[str, np.ndarray]  # revolute: force of a on b; prismatic: (N, couple)
    members: dict[str, Member]


@dataclass(frozen=True)
class Solution:
    """The force analysis of one position: total, per group, kinematics and checks."""

    linkage: Linkage
    analysis: Analysis
    total: GroupResult
    groups: dict[str, GroupResult]
    states: dict[str, BodyState]
    virtual_work_driver: float
    virtual_work_residual: float
    condition_number: float

    @property
    def driver(self) -> float:
        return self.total.driver


def _unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def load_point(link: Linkage, body: str, at: str, along_: float, across: float) -> P:
    """World point (jets) *along*/*across* the axis of *body* from point *at* (origin if empty)."""
    b = link.bodies[body]
    base = link.points[at] if at else b.origin
    return along(base, b.angle, along_, across)


def body_states(link: Linkage, an: Analysis) -> dict[str, BodyState]:
    """Kinematics of every moving body's centre of mass, with its mass properties."""
    out = {}
    for name, b in link.bodies.items():
        mp = an.mass.get(name)
        g = load_point(link, name, mp.at, mp.along, mp.across) if mp else b.origin
        out[name] = BodyState(
            float(b.angle.v),
            float(b.angle.d),
            float(b.angle.dd),
            g.pos(),
            g.vel(),
            g.acc(),
            mp.mass if mp else 0.0,
            mp.inertia if mp else 0.0,
        )
    return out


def _load_vector(link: Linkage, ld: Load) -> np.ndarray:
    if ld.relative_angle:
        mag, rel = ld.force
        return mag * _unit(float(link.bodies[ld.body].angle.v) + rel)
    return np.asarray(ld.force, dtype=float)


def _known_forces(link: Linkage, an: Analysis, states: dict[str, BodyState]):
    """Yield (group, body, Load or None, force vector, couple, kind, name) of every known load.

    A None load acts at the body's centre of mass (gravity, inertia).
    """
    for i, ld in enumerate(an.loads):
        yield ld.group, ld.body, ld, _load_vector(link, ld), ld.torque, "load", ld.group or f"load{i}"
    for name, st in states.items():
        g_pt = None  # at the centre of mass, whose position and velocity BodyState holds
        if an.gravity is not None and st.mass:
            yield "gravity", name, g_pt, st.mass * np.asarray(an.gravity), 0.0, "gravity", f"W[{name}]"
        if an.dynamic and (st.mass or st.inertia):
            yield (f"inertia:{name}", name, g_pt, st.inertia_force, st.inertia_couple, "inertia", f"Fi[{name}]")


def solve(link: Linkage, an: Analysis, virtual: Linkage | None = None) -> Solution:
    """Solve the equilibrium of every moving body of *link* under the loads of *an*.

    Args:
        link: the mechanism position with its kinematics.
        an: loads, mass properties, gravity and whether inertia is included.
        virtual: the same position at unit input speed, for the virtual-work check when the
            input speed of *link* is zero (defaults to *link* itself).

    Raises:
        ConditioningError: the system's condition number exceeds ``an.max_condition``.
    """
    names = list(link.bodies)
    row = {n: 3 * i for i, n in enumerate(names)}
    origin = {n: link.bodies[n].origin.pos() for n in names}
    ncol = 2 * len(link.joints) + 1
    nrow = 3 * len(names)
    A = np.zeros((nrow, ncol))
    scale = link.scale

    def put(body: str, col: int, f: np.ndarray, point: np.ndarray, couple: float = 0.0) -> None:
        if body == GROUND:
            return
        r = row[body]
        A[r, col] += f[0]
        A[r + 1, col] += f[1]
        A[r + 2, col] += _cross(point - origin[body], f) + couple

    couple_cols = [ncol - 1]
    for k, j in enumerate(link.joints):
        c = 2 * k
        pt = j.point.pos()
        if isinstance(j, Prismatic):
            n = _unit(float(j.axis.v) + math.pi / 2)
            put(j.block, c, n, pt)
            put(j.guide, c, -n, pt)
            put(j.block, c + 1, np.zeros(2), pt, 1.0)
            put(j.guide, c + 1, np.zeros(2), pt, -1.0)
            couple_cols.append(c + 1)
        else:
            for axis in (0, 1):
                e = np.eye(2)[axis]
                put(j.b, c + axis, e, pt)
                put(j.a, c + axis, -e, pt)
    drv = link.driver
    if drv.kind == "torque":
        put(drv.body, ncol - 1, np.zeros(2), origin[drv.body], 1.0)
    else:
        jnt = next(j for j in link.joints if j.name == drv.joint)
        put(drv.body, ncol - 1, _unit(float(jnt.axis.v)), jnt.point.pos())
        couple_cols.remove(ncol - 1)

    states = body_states(link, an)
    known = list(_known_forces(link, an, states))
    group_names = list(dict.fromkeys(k[0] for k in known))
    B = np.zeros((nrow, len(group_names)))
    for grp, body, ld, f, tq, _kind, _name in known:
        p = _where(link, ld) if ld is not None else states[body].g
        r, gcol = row[body], group_names.index(grp)
        B[r, gcol] += f[0]
        B[r + 1, gcol] += f[1]
        B[r + 2, gcol] += _cross(p - origin[body], f) + tq

    # Unit-free conditioning: moment rows / L, couple columns × L.
    rs = np.ones(nrow)
    rs[2::3] = 1.0 / scale
    cs = np.ones(ncol)
    cs[couple_cols] = scale
    cond = float(np.linalg.cond(A * rs[:, None] * cs[None, :]))
    if not math.isfinite(cond) or cond > an.max_condition:
        raise ConditioningError(
            f"the equilibrium equations are singular or nearly so (condition number {cond:.3g} > "
            f"{an.max_condition:.3g}, transmission angle {link.transmission:.3g}°): the mechanism "
            "is at or too near a toggle or dead-centre position for this driver"
        )
    X = -np.linalg.solve(A, B) if group_names else np.zeros((ncol, 0))
    total_x = X.sum(axis=1) if group_names else np.zeros(ncol)

    def result(x: np.ndarray, grp: str | None) -> GroupResult:
        joints = {j.name: np.array(x[2 * k : 2 * k + 2]) for k, j in enumerate(link.joints)}
        members = _members(link, an, states, known, joints, float(x[-1]), grp)
        return GroupResult(float(x[-1]), joints, members)

    total = result(total_x, None)
    groups = {g: result(X[:, i], g) for i, g in enumerate(group_names)}
    vw = _virtual_work(link, virtual or link, an, states, known)
    q = total.driver
    # Relative to the driver, the work terms and the load level of the whole system (a load at a
    # fixed pivot does no work but sets the size of the roundoff in every unknown).
    load_level = float(np.abs(B * rs[:, None]).max()) * scale if B.size else 0.0
    if drv.kind == "force":
        load_level /= scale
    denom = max(abs(q), vw[1], load_level, 1e-300)
    return Solution(link, an, total, groups, states, vw[0], abs(vw[0] - q) / denom, cond)


def _virtual_work(link: Linkage, virt: Linkage, an: Analysis, states, known) -> tuple[float, float]:
    """Driver value from the power balance, and the scale of the terms (for a relative residual)."""
    speed = float(link.bodies[link.input_body].angle.d)
    ratio = 1.0 / speed if (virt is link and speed) else 1.0
    if virt is link and not speed:
        raise ValueError("a virtual-work check at zero input speed needs a unit-speed linkage")
    vstates = body_states(virt, an)
    terms = []
    for _grp, body, ld, f, tq, _kind, _name in known:
        b = virt.bodies[body]
        if ld is not None:
            v = load_point(virt, ld.body, ld.at, ld.along, ld.across).vel()
        else:
            v = vstates[body].v_g
        terms.append((float(np.dot(f, v)) + tq * float(b.angle.d)) * ratio)
    drv = virt.driver
    if drv.kind == "torque":
        vd = float(virt.bodies[drv.body].angle.d) * ratio
    else:
        jnt = next(j for j in virt.joints if j.name == drv.joint)
        vd = float(np.dot(jnt.point.vel(), _unit(float(jnt.axis.v)))) * ratio
    if abs(vd) < 1e-12:
        return math.nan, math.inf
    total = sum(terms)
    return -total / vd, sum(abs(t) for t in terms) / abs(vd)


def _where(link: Linkage, ld: Load) -> np.ndarray:
    return load_point(link, ld.body, ld.at, ld.along, ld.across).pos()


def _offset_force(name: str, body: str, point: np.ndarray, f: np.ndarray, couple: float, kind: str) -> AppliedForce:
    """Merge a force and a couple into one force with a shifted line of action."""
    f2 = float(f @ f)
    if couple and f2 > 0:
        point = point + couple / f2 * np.array([f[1], -f[0]])
    return AppliedForce(name, body, point, f, kind)


def _members(link: Linkage, an: Analysis, states, known, joints, driver: float, grp: str | None) -> dict[str, Member]:
    acting: dict[str, list[AppliedForce]] = {n: [] for n in link.bodies}
    couples: dict[str, list[tuple[str, float]]] = {n: [] for n in link.bodies}
    for j in link.joints:
        pt = j.point.pos()
        if isinstance(j, Prismatic):
            n_, c = joints[j.name]
            vec = n_ * _unit(float(j.axis.v) + math.pi / 2)
            for body, sgn in ((j.block, 1.0), (j.guide, -1.0)):
                if body != GROUND:
                    acting[body].append(_offset_force(j.name, body, pt, sgn * vec, sgn * c, "normal"))
        else:
            for body, sgn in ((j.b, 1.0), (j.a, -1.0)):
                if body != GROUND:
                    acting[body].append(AppliedForce(j.name, body, pt, sgn * joints[j.name], "pin"))
    for g, body, ld, f, tq, kind, name in known:
        if grp is not None and g != grp:
            continue
        p = _where(link, ld) if ld is not None else states[body].g
        if kind == "inertia":
            acting[body].append(_offset_force(name, body, p, f, tq, kind))
        else:
            if np.any(f):
                acting[body].append(AppliedForce(name, body, p, np.asarray(f, float), kind))
            if tq:
                couples[body].append((name, tq))
    drv = link.driver
    if drv.kind == "torque":
        couples[drv.body].append(("driver", driver))
    else:
        jnt = next(j for j in link.joints if j.name == drv.joint)
        acting[drv.body].append(
            AppliedForce("driver", drv.body, jnt.point.pos(), driver * _unit(float(jnt.axis.v)), "driver")
        )
    out = {}
    for body in link.bodies:
        scale = max((float(np.hypot(*f.vector)) for f in acting[body]), default=0.0)
        forces = tuple(f for f in acting[body] if np.hypot(*f.vector) > 1e-12 * max(scale, 1e-300))
        cpl = tuple(c for c in couples[body] if abs(c[1]) > 0)
        kind = "general"
        if not cpl and len(forces) == 2:
            kind = "two-force"
        elif not cpl and len(forces) == 3:
            kind = "three-force"
        elif len(cpl) == 1 and len(forces) == 2:
            kind = "two-forces-and-couple"
        conc = None
        if kind == "three-force":
            conc = _intersection(forces[0], forces[1])
        poly = np.vstack([np.zeros(2)] + [f.vector for f in forces]).cumsum(axis=0)
        out[body] = Member(body, forces, cpl, kind, conc, poly)
    return out


def _intersection(f1: AppliedForce, f2: AppliedForce) -> np.ndarray | None:
    d1, d2 = f1.vector, f2.vector
    den = _cross(d1, d2)
    if abs(den) < 1e-12 * float(np.hypot(*d1) * np.hypot(*d2)):
        return None
    t = _cross(f2.point - f1.point, d2) / den
    return f1.point + t * d1
