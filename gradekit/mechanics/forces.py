"""Static and dynamic (d'Alembert) force analysis of mechanism positions, batched.

Every moving body contributes three equilibrium equations (forces in x and y, moments about the
body's origin) including inertia forces −m·a_G and couples −I_G·α. The unknowns are the pin
forces, each slider's normal force and couple, and the driving torque or force. The loads of each
superposition group (each named load, gravity, each body's inertia) form one right-hand side, so
the solution for every group and their sum come from one factorisation.

All variants of a batch share one topology, so the systems are assembled into one (N, m, m)
array and solved, conditioned and cross-checked together (`solve_many`); `solve` is the same for
one variant. The driving torque is cross-checked by virtual work (power balance including
inertia terms), which uses only the kinematics, not the matrix. The free-body data a figure
needs (`Member`) is computed only when a figure or key asks for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from gradekit.mechanics.errors import ConditioningError, GeometryError
from gradekit.mechanics.jet import Jet, P, along
from gradekit.mechanics.model import (
    GROUND,
    Analysis,
    Batched,
    Linkage,
    Load,
    MotionLoad,
    Prismatic,
    Refusals,
    Spot,
)

VW_LIMIT = 1e-9


def _cross(r: np.ndarray, f: np.ndarray):
    return r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]


def _num(x):
    """A float for a 0-d value, the array otherwise."""
    return float(x) if np.ndim(x) == 0 else x


def _xy(x, y) -> np.ndarray:
    """Stack two (broadcastable) coordinate arrays into (..., 2)."""
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    return np.stack([x, y], axis=-1)


def _unit(angle) -> np.ndarray:
    return _xy(np.cos(angle), np.sin(angle))


def _col(x) -> np.ndarray:
    """A per-variant scalar as a column that scales (..., 2) vectors."""
    return np.asarray(x, float)[..., None]


@dataclass(frozen=True)
class BodyState:
    """Kinematics and inertia of one body (or one body in every variant of a batch); SI.

    ``angle``, ``omega``, ``alpha``, ``mass`` and ``inertia`` are floats (or (N,) arrays);
    ``g``, ``v_g`` and ``a_g`` are world (x, y) vectors of shape (2,) (or (N, 2)).
    """

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
        return -_col(self.mass) * self.a_g

    @property
    def inertia_couple(self) -> float:
        return _num(-np.asarray(self.inertia) * self.alpha)

    @property
    def offset(self) -> float:
        """h = I·α / (m·|a_G|): distance of the equivalent offset inertia force from G."""
        f = np.hypot(self.inertia_force[..., 0], self.inertia_force[..., 1])
        c = np.abs(self.inertia_couple)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = np.where(f > 0, c / np.where(f > 0, f, 1.0), np.where(c != 0, math.inf, 0.0))
        return _num(h)

    def take(self, i: int) -> BodyState:
        def t(x):
            return float(x[i]) if np.ndim(x) else float(x)

        def v(x):
            return np.array(x[i] if np.ndim(x) == 2 else x, dtype=float)

        return BodyState(
            t(self.angle), t(self.omega), t(self.alpha), v(self.g), v(self.v_g), v(self.a_g), t(self.mass),
            t(self.inertia),
        )


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
    """Driver value and joint reactions due to one superposition group (or the total).

    ``members`` (the free-body data of the graphical method) is built on first use.
    """

    driver: float
    joints: dict[str, np.ndarray]  # revolute: force of a on b; prismatic: (N, couple)
    _members: object = field(default=None, repr=False, compare=False)

    @cached_property
    def members(self) -> dict[str, Member]:
        return self._members()


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
    # the assembled equilibrium system A·x + B = 0 (rows: ΣFx, ΣFy, ΣM about the body's origin per
    # body; columns: two per joint in joint order, then the driver; B: one column per group)
    matrix: np.ndarray | None = field(default=None, repr=False, compare=False)
    rhs: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def driver(self) -> float:
        return self.total.driver


class Conditioning:
    """The 2-norm condition numbers κ of a batch of unit-free systems, exact but computed lazily.

    An SVD per system costs more than assembling and solving it, and most questions are "is κ
    above this bound?". The Frobenius condition number κ_F = ‖A‖_F·‖A⁻¹‖_F bounds the answer:
    κ_F / n ≤ κ ≤ κ_F for an n×n system, so an SVD is needed only for the variants whose bound
    straddles the limit (and for the values someone reads). Refused (NaN) systems have κ = inf.

    The systems are S = diag(*rows*)·*a*·diag(*cols*) (the unit-free scaling; none by default) and
    *inverses* are a⁻¹·diag(*rows*)⁻¹, what one solve with those right-hand sides gives (None: an
    exactly singular system in the batch, no cheap bound). Neither S nor S⁻¹ is formed for the whole
    batch: at class scale each is as large as the system itself, and the Frobenius norms are sums.
    """

    def __init__(self, a: np.ndarray, refused: np.ndarray, inverses: np.ndarray | None,
                 rows: np.ndarray | None = None, cols: np.ndarray | None = None) -> None:
        self.a = a
        self.refused = refused
        self.rows = np.ones(a.shape[:2]) if rows is None else rows
        self.cols = np.ones((a.shape[0], a.shape[2])) if cols is None else cols
        n = a.shape[-1]
        with np.errstate(all="ignore"):
            if inverses is not None:  # ‖S‖_F² = Σ (r_i a_ij c_j)², ‖S⁻¹‖_F² = Σ (inv_ij / c_i)²
                upper = np.sqrt(np.einsum("nij,nij,ni,nj->n", a, a, self.rows**2, self.cols**2)
                                * np.einsum("nij,nij,ni->n", inverses, inverses, self.cols**-2.0))
            else:
                upper = np.full(len(a), np.nan)
        # a hair of slack on both bounds, so rounding in κ_F never decides what only an SVD can
        self.upper = np.where(refused, np.inf, upper * (1 + 1e-9))
        self.lower = self.upper / n * (1 - 2e-9)
        self._exact = np.full(len(a), np.nan)

    def systems(self, mask: np.ndarray) -> np.ndarray:
        """The unit-free systems S of the variants *mask* selects."""
        return self.rows[mask][:, :, None] * self.a[mask] * self.cols[mask][:, None, :]

    def take(self, mask: np.ndarray) -> Conditioning:
        """The variants *mask* selects, their κ not yet computed."""
        return Conditioning(self.a[mask], self.refused[mask], None, self.rows[mask], self.cols[mask])

    def _compute(self, mask: np.ndarray) -> None:
        todo = mask & np.isnan(self._exact)
        if todo.any():
            with np.errstate(all="ignore"):
                try:
                    self._exact[todo] = np.linalg.cond(self.systems(todo))
                except np.linalg.LinAlgError:
                    self._exact[todo] = [_cond1(a) for a in self.systems(todo)]
            self._exact[todo & self.refused] = np.inf
            self._exact[todo & ~np.isfinite(self._exact)] = np.inf

    def above(self, limit) -> np.ndarray:
        """Where κ > *limit* or is not finite, deciding by the bounds where they suffice."""
        limit = np.broadcast_to(np.asarray(limit, float), self.upper.shape)
        sure = np.isfinite(self.upper)
        unsure = ~sure | ((self.upper > limit) & (self.lower <= limit))
        self._compute(unsure & ~self.refused)
        exact = np.where(self.refused, np.inf, self._exact)
        return np.where(unsure | self.refused, ~(exact <= limit), self.lower > limit)

    def at(self, i: int) -> float:
        mask = np.zeros(len(self.upper), bool)
        mask[i] = True
        self._compute(mask)
        return float(np.inf if self.refused[i] else self._exact[i])

    @property
    def values(self) -> np.ndarray:
        self._compute(~self.refused)
        return np.where(self.refused, np.inf, self._exact)


def _cond1(a: np.ndarray) -> float:
    try:
        return float(np.linalg.cond(a))
    except np.linalg.LinAlgError:
        return math.inf


@dataclass(frozen=True)
class Solutions(Batched):
    """The force analysis of a batch of variants of one topology.

    ``x[i, :, g]`` are the unknowns of variant *i* due to group ``group_names[g]`` (the columns:
    two per joint in joint order, then the driver); ``total`` their sum over groups. ``ok`` is
    False for every refused variant, whose reason ``refused.reason(i)`` gives (it could not be
    assembled, its motion is undefined, or its system is too ill-conditioned; the last also in
    ``ill_conditioned``). Numbers of refused variants are meaningless.
    """

    linkage: Linkage
    analysis: Analysis
    group_names: tuple[str, ...]
    x: np.ndarray
    total: np.ndarray
    states: dict[str, BodyState]
    virtual_work_driver: np.ndarray
    virtual_work_residual: np.ndarray
    conditioning: Conditioning
    refused: Refusals
    ill_conditioned: np.ndarray
    matrix: np.ndarray | None = field(default=None, repr=False, compare=False)  # (N, m, m): A of A·x + B = 0
    rhs: np.ndarray | None = field(default=None, repr=False, compare=False)  # (N, m, G): B, one column per group

    @property
    def condition_number(self) -> np.ndarray:
        """The 2-norm condition number of every variant's unit-free system (inf where refused)."""
        return self.conditioning.values

    @property
    def driver(self) -> np.ndarray:
        return self.total[:, -1]

    def joint(self, name: str, x: np.ndarray | None = None) -> np.ndarray:
        """The (N, 2) unknowns of joint *name* from the (N, ncol) array *x* (the total by default)."""
        k = next(k for k, j in enumerate(self.linkage.joints) if j.name == name)
        return (self.total if x is None else x)[:, 2 * k : 2 * k + 2]

    def at(self, i: int) -> Solution:
        """Variant *i* as a `Solution` (raises the variant's error when it was refused)."""
        if self.refused.mask[i]:
            cls = ConditioningError if self.ill_conditioned[i] else GeometryError
            raise cls(self.refused.reason(i))
        link = self.linkage.take(i) if self.n > 1 or np.ndim(self.linkage.scale) else self.linkage
        an = self.analysis.take(i)
        states = {n: st.take(i) for n, st in self.states.items()}
        known = list(_known_forces(link, an, states))

        def result(x: np.ndarray, grp: str | None) -> GroupResult:
            joints = {j.name: np.array(x[2 * k : 2 * k + 2]) for k, j in enumerate(link.joints)}
            drv = float(x[-1])
            return GroupResult(drv, joints, lambda: _members(link, an, states, known, joints, drv, grp))

        return Solution(
            link,
            an,
            result(self.total[i], None),
            {g: result(self.x[i, :, k], g) for k, g in enumerate(self.group_names)},
            states,
            float(self.virtual_work_driver[i]),
            float(self.virtual_work_residual[i]),
            self.conditioning.at(i),
            None if self.matrix is None else self.matrix[i],
            None if self.rhs is None else self.rhs[i],
        )


def load_point(link: Linkage, body: str, at: str, along_, across) -> P:
    """World point (jets) *along*/*across* the axis of *body* from point *at* (origin if empty)."""
    b = link.bodies[body]
    base = link.points[at] if at else b.origin
    return along(base, b.angle, along_, across)


def _pos(p: P) -> np.ndarray:
    return _xy(p.x.v, p.y.v)


def _vel(p: P) -> np.ndarray:
    return _xy(p.x.d, p.y.d)


def _acc(p: P) -> np.ndarray:
    return _xy(p.x.dd, p.y.dd)


def body_states(link: Linkage, an: Analysis) -> dict[str, BodyState]:
    """Kinematics of every moving body's centre of mass, with its mass properties."""
    out = {}
    for name, b in link.bodies.items():
        mp = an.mass.get(name)
        g = load_point(link, name, mp.at, mp.along, mp.across) if mp else b.origin
        out[name] = BodyState(
            b.angle.v, b.angle.d, b.angle.dd, _pos(g), _vel(g), _acc(g), mp.mass if mp else 0.0,
            mp.inertia if mp else 0.0,
        )
    return out


def _load_vector(link: Linkage, ld: Load) -> np.ndarray:
    if ld.relative_angle:
        mag, rel = ld.force
        return _col(mag) * _unit(link.bodies[ld.body].angle.v + rel)
    return _xy(*ld.force)


def spot_point(link: Linkage, spot: Spot) -> P:
    """The world point (jets) of a point fixed on a body, the ground included."""
    if spot.body == GROUND:
        base = link.points[spot.at] if spot.at else P.fixed(0.0, 0.0)
        return along(base, Jet(0.0), spot.along, spot.across)
    return load_point(link, spot.body, spot.at, spot.along, spot.across)


def _motion_forces(link: Linkage, ml: MotionLoad):
    """Yield (body, Load locating the point, force vector, couple) of one motion-dependent load,
    computed from *link*'s kinematics (bodies other than the ground only)."""
    if ml.kind == "rotary_damper":
        rate = link.bodies[ml.body].angle.d - (link.bodies[ml.other].angle.d if ml.other != GROUND else 0.0)
        couple = -np.asarray(ml.coefficient) * rate
        yield ml.body, None, np.zeros(2), _num(couple)
        if ml.other != GROUND:
            yield ml.other, None, np.zeros(2), _num(-couple)
        return
    pts = [spot_point(link, e) for e in ml.ends]
    if ml.kind == "resistance":
        v = _vel(pts[0])
        speed = np.hypot(v[..., 0], v[..., 1])
        with np.errstate(all="ignore"):
            f = -_col(ml.coefficient) * np.where(_col(speed) > 0, v / _col(np.where(speed > 0, speed, 1.0)), 0.0)
        end = ml.ends[0]
        yield end.body, Load(ml.group, end.body, (0.0, 0.0), 0.0, end.at, end.along, end.across), f, 0.0
        return
    d = _pos(pts[1]) - _pos(pts[0])
    length = np.hypot(d[..., 0], d[..., 1])
    u = d / _col(np.where(length > 0, length, 1.0))
    if ml.kind == "damper":
        size = _col(ml.coefficient) * _col(np.sum((_vel(pts[1]) - _vel(pts[0])) * u, axis=-1))
    else:  # spring
        size = _col(ml.coefficient) * _col(length - np.asarray(ml.free_length, float))
    on_q = -size * u
    for end, f in ((ml.ends[0], -on_q), (ml.ends[1], on_q)):
        if end.body != GROUND:
            yield end.body, Load(ml.group, end.body, (0.0, 0.0), 0.0, end.at, end.along, end.across), f, 0.0


def _motion_refusals(link: Linkage, an: Analysis, refused: Refusals) -> None:
    """A resistance opposes its point's velocity: undefined where that point is at rest; a damper or
    spring has no direction where its ends coincide."""
    for ml in an.motion_loads:
        pts = [spot_point(link, e) for e in ml.ends]
        if ml.kind == "resistance":
            v = _vel(pts[0])
            still = np.hypot(v[..., 0], v[..., 1]) <= 1e-12 * np.abs(link.bodies[link.input_body].angle.d) * link.scale
            refused.add(still, lambda i, g=ml.group: f"load {g}: the point it resists is at rest here, so its "
                        "direction is undefined; choose another crank angle")
        elif pts:
            d = _pos(pts[1]) - _pos(pts[0])
            refused.add(np.hypot(d[..., 0], d[..., 1]) <= 1e-12 * link.scale,
                        lambda i, g=ml.group: f"load {g}: its two ends coincide, so its direction is undefined")


def frame_reaction(link: Linkage, x: np.ndarray, about: np.ndarray):
    """The shaking force and moment: what the mechanism exerts on the frame through its ground pins
    and slides, plus the reaction of the driver (whose motor or actuator sits on the frame).

    *x*: (N, ncol) unknowns (a group's or the total); *about*: (N, 2) or (2,) the moment centre.
    Returns ((N, 2) force, (N,) moment about *about*, CCW positive).
    """
    n = x.shape[0]
    force = np.zeros((n, 2))
    moment = np.zeros(n)

    def add(f, point, couple=0.0):
        nonlocal force, moment
        f = np.broadcast_to(f, (n, 2))
        force = force + f
        moment = moment + _cross(np.broadcast_to(point, (n, 2)) - about, f) + couple

    for k, j in enumerate(link.joints):
        u = x[:, 2 * k : 2 * k + 2]
        pt = _pos(j.point)
        if isinstance(j, Prismatic):
            if j.guide == GROUND:  # unknowns: normal force and couple of the guide on the block
                add(-_col(u[:, 0]) * _unit(j.axis.v + math.pi / 2), pt, -u[:, 1])
        elif j.a == GROUND:  # the force of the ground on body b
            add(-u, pt)
        elif j.b == GROUND:
            add(u, pt)
    drv = link.driver
    if drv.kind == "torque":
        moment = moment - x[:, -1]
    else:
        jnt = next(j for j in link.joints if j.name == drv.joint)
        add(-_col(x[:, -1]) * _unit(jnt.axis.v), _pos(jnt.point))
    return force, moment


def _known_forces(link: Linkage, an: Analysis, states: dict[str, BodyState]):
    """Yield (group, body, Load or None, force vector, couple, kind, name) of every known load.

    A None load acts at the body's centre of mass (gravity, inertia). Motion-dependent loads
    (dampers, springs, resistances) are computed here from the kinematics, so the equilibrium and
    the virtual-work check use the same forces.
    """
    for i, ld in enumerate(an.loads):
        yield ld.group, ld.body, ld, _load_vector(link, ld), ld.torque, "load", ld.group or f"load{i}"
    for ml in an.motion_loads:
        for body, ld, f, tq in _motion_forces(link, ml):
            yield ml.group, body, ld, f, tq, "load", ml.group
    for name, st in states.items():
        has_mass = np.any(np.asarray(st.mass) != 0)
        if an.gravity is not None and has_mass:
            yield "gravity", name, None, _col(st.mass) * _xy(*an.gravity), 0.0, "gravity", f"W[{name}]"
        if an.dynamic and (has_mass or np.any(np.asarray(st.inertia) != 0)):
            yield (f"inertia:{name}", name, None, st.inertia_force, st.inertia_couple, "inertia", f"Fi[{name}]")


def _where(link: Linkage, ld: Load) -> np.ndarray:
    return _pos(load_point(link, ld.body, ld.at, ld.along, ld.across))


def solve_many(link: Linkage, an: Analysis, virtual: Linkage | None = None) -> Solutions:
    """Solve the equilibrium of every moving body in every variant of *link* under *an*'s loads.

    Args:
        link: the (batched) mechanism positions with their kinematics.
        an: loads, mass properties, gravity and whether inertia is included (floats or arrays).
        virtual: the same positions at unit input speed, for the virtual-work check of variants
            whose input speed is zero (those variants are refused without it).

    Returns:
        `Solutions`, with refused variants masked (``ok``) and their reasons, never raising for one.
    """
    refused = link.refused.copy() if link.refused is not None else Refusals(int(np.size(link.scale)))
    n = refused.n
    names = list(link.bodies)
    row = {b: 3 * i for i, b in enumerate(names)}
    origin = {b: _pos(link.bodies[b].origin) for b in names}
    ncol = 2 * len(link.joints) + 1
    nrow = 3 * len(names)
    A = np.zeros((n, nrow, ncol))
    scale = np.broadcast_to(np.asarray(link.scale, float), (n,))

    def put(target: np.ndarray, body: str, col: int, f, point, couple=0.0) -> None:
        if body == GROUND:
            return
        r = row[body]
        f = np.broadcast_to(f, (n, 2))
        target[:, r, col] += f[:, 0]
        target[:, r + 1, col] += f[:, 1]
        target[:, r + 2, col] += _cross(point - origin[body], f) + couple

    zero = np.zeros(2)
    couple_cols = [ncol - 1]
    with np.errstate(all="ignore"):
        for k, j in enumerate(link.joints):
            c = 2 * k
            pt = _pos(j.point)
            if isinstance(j, Prismatic):
                nrm = _unit(j.axis.v + math.pi / 2)
                put(A, j.block, c, nrm, pt)
                put(A, j.guide, c, -nrm, pt)
                put(A, j.block, c + 1, zero, pt, 1.0)
                put(A, j.guide, c + 1, zero, pt, -1.0)
                couple_cols.append(c + 1)
            else:
                for axis in (0, 1):
                    e = np.eye(2)[axis]
                    put(A, j.b, c + axis, e, pt)
                    put(A, j.a, c + axis, -e, pt)
        drv = link.driver
        if drv.kind == "torque":
            put(A, drv.body, ncol - 1, zero, origin[drv.body], 1.0)
        else:
            jnt = next(j for j in link.joints if j.name == drv.joint)
            put(A, drv.body, ncol - 1, _unit(jnt.axis.v), _pos(jnt.point))
            couple_cols.remove(ncol - 1)

        states = body_states(link, an)
        _motion_refusals(link, an, refused)
        known = list(_known_forces(link, an, states))
        group_names = tuple(dict.fromkeys(kf[0] for kf in known))
        B = np.zeros((n, nrow, len(group_names)))
        for grp, body, ld, f, tq, _kind, _name in known:
            p = _where(link, ld) if ld is not None else states[body].g
            put(B, body, group_names.index(grp), f, p, tq)

        # Unit-free conditioning: moment rows / L, couple columns × L.
        rs = np.ones((n, nrow))
        rs[:, 2::3] = 1.0 / scale[:, None]
        cs = np.ones((n, ncol))
        cs[:, couple_cols] = scale[:, None]
        geometry_bad = refused.mask.copy()
        eye = np.eye(nrow, ncol)
        A_safe = A
        if geometry_bad.any():  # refused variants get an identity, so the batch still factorises
            A_safe = np.where(geometry_bad[:, None, None], eye, A)
        g = len(group_names)
        # One factorisation gives the unknowns of every group and the inverse of the unit-free
        # system (A⁻¹·R⁻¹ = C·S⁻¹ for S = R·A·C), whose norm bounds the condition number.
        rhs = np.zeros((n, nrow, g + nrow))
        rhs[:, :, :g] = B
        diag = np.arange(nrow)
        rhs[:, diag, g + diag] = 1.0 / rs
        try:
            Y = np.linalg.solve(A_safe, rhs)
            cond = Conditioning(A_safe, geometry_bad, Y[:, :, g:], rs, cs)
        except np.linalg.LinAlgError:  # an exactly singular system (a toggle): refuse it, then solve
            Y = None
            cond = Conditioning(A_safe, geometry_bad, None, rs, cs)
        max_cond = np.broadcast_to(np.asarray(an.max_condition, float), (n,))
        ill = ~geometry_bad & cond.above(max_cond)
        refused.add(
            ill,
            lambda i: (
                f"the equilibrium equations are singular or nearly so (condition number {cond.at(i):.3g} > "
                f"{max_cond[i]:.3g}, transmission angle {_at(link.transmission, i):.3g}°): the mechanism "
                "is at or too near a toggle or dead-centre position for this driver"
            ),
        )
        if Y is None:
            Y = np.linalg.solve(np.where(refused.mask[:, None, None], eye, A), B)
        X = -Y[:, :, :g]
        total = X.sum(axis=-1) if g else np.zeros((n, ncol))

        vw_driver, vw_scale = _virtual_work(link, virtual, an, states, known, n)
        q = total[:, -1]
        # Relative to the driver, the work terms and the load level of the whole system (a load at
        # a fixed pivot does no work but sets the size of the roundoff in every unknown).
        load_level = np.abs(B * rs[:, :, None]).max(axis=(1, 2)) * scale if B.size else np.zeros(n)
        if drv.kind == "force":
            load_level = load_level / scale
        denom = np.maximum.reduce([np.abs(q), vw_scale, load_level, np.full(n, 1e-300)])
        residual = np.abs(vw_driver - q) / denom
    return Solutions(link, an, group_names, X, total, states, vw_driver, residual, cond, refused, ill, A, B)


def _at(x, i: int) -> float:
    return float(x[i]) if np.ndim(x) else float(x)


def solve(link: Linkage, an: Analysis, virtual: Linkage | None = None) -> Solution:
    """Solve the equilibrium of one position (floats); see `solve_many`.

    Raises:
        GeometryError: the position cannot be assembled.
        ConditioningError: the system's condition number exceeds ``an.max_condition``.
        ValueError: the input speed is zero and no unit-speed *virtual* linkage was given.
    """
    if virtual is None and not float(np.asarray(link.bodies[link.input_body].angle.d)):
        raise ValueError("a virtual-work check at zero input speed needs a unit-speed linkage")
    return solve_many(link, an, virtual).at(0)


def _virtual_work(link: Linkage, virtual: Linkage | None, an: Analysis, states, known, n: int):
    """Driver value from the power balance, and the scale of the terms (for a relative residual).

    Velocities come from *link* divided by its input speed, or, where that speed is zero, from
    the unit-speed *virtual* linkage.
    """
    speed = np.broadcast_to(np.asarray(link.bodies[link.input_body].angle.d, float), (n,))
    moving = speed != 0
    out_q, out_s = np.full(n, math.nan), np.full(n, math.inf)
    sources = [(link, np.where(moving, 1.0 / np.where(moving, speed, 1.0), 0.0), moving, states)]
    if virtual is not None and not moving.all():
        sources.append((virtual, np.ones(n), ~moving, body_states(virtual, an)))
    for virt, ratio, use, vstates in sources:
        total = np.zeros(n)
        size = np.zeros(n)
        for _grp, body, ld, f, tq, _kind, _name in known:
            b = virt.bodies[body]
            v = _vel(load_point(virt, ld.body, ld.at, ld.along, ld.across)) if ld is not None else vstates[body].v_g
            t = (np.sum(np.broadcast_to(f, (n, 2)) * np.broadcast_to(v, (n, 2)), axis=-1) + tq * b.angle.d) * ratio
            total = total + t
            size = size + np.abs(t)
        drv = virt.driver
        if drv.kind == "torque":
            vd = virt.bodies[drv.body].angle.d * ratio
        else:
            jnt = next(j for j in virt.joints if j.name == drv.joint)
            vd = np.sum(_vel(jnt.point) * _unit(jnt.axis.v), axis=-1) * ratio
        vd = np.broadcast_to(vd, (n,))
        fine = use & (np.abs(vd) >= 1e-12)
        safe = np.where(fine, vd, 1.0)
        out_q = np.where(fine, -total / safe, out_q)
        out_s = np.where(fine, size / np.abs(safe), out_s)
    return out_q, out_s


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
