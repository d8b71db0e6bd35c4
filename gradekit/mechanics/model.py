"""Frozen records of mechanism positions: bodies, joints, driver, loads and mass properties.

A record holds one variant (floats) or many (arrays with one entry per variant, the batch axis
first); the topology (which joint touches which body) is the same for every variant of a batch.
Conventions: SI units (m, kg, s, N, rad) inside the core; angles CCW from +x; torques and
angular rates CCW positive; a revolute joint's unknown is the force of body ``a`` on body ``b``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gradekit.mechanics.jet import Jet, P, take

GROUND = "ground"


class Batched:
    """A batch of variants with a ``refused: Refusals`` field: its size and its accepted mask."""

    refused: Refusals

    @property
    def n(self) -> int:
        return self.refused.n

    @property
    def ok(self) -> np.ndarray:
        return ~self.refused.mask


@dataclass(frozen=True)
class Body:
    """A moving link: its frame (origin point and axis angle, both jets) and display label."""

    name: str
    origin: P
    angle: Jet
    label: str = ""


@dataclass(frozen=True)
class Revolute:
    """A pin between bodies *a* and *b* at *point*; unknown: force of a on b (2 components)."""

    name: str
    a: str
    b: str
    point: P


@dataclass(frozen=True)
class Prismatic:
    """Block *block* slides along *guide* on the line through *point* at *axis*.

    Unknowns: the normal force of guide on block (along the axis' left normal, at *point*) and
    the couple of guide on block.
    """

    name: str
    guide: str
    block: str
    point: P
    axis: Jet


Joint = Revolute | Prismatic


def _take(x, i: int):
    return float(x[i]) if np.ndim(x) else float(x)


def take_joint(j: Joint, i: int) -> Joint:
    if isinstance(j, Prismatic):
        return Prismatic(j.name, j.guide, j.block, j.point.take(i), take(j.axis, i))
    return Revolute(j.name, j.a, j.b, j.point.take(i))


class Refusals:
    """Which variants of a batch are refused, and why (the first reason found for each).

    ``mask[i]`` is True for a refused variant; ``reason(i)`` formats its message (lazily: the
    messages of a large batch are only written for the variants someone asks about).
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.mask = np.zeros(n, bool)
        self._checks: list[tuple[np.ndarray, Callable[[int], str]]] = []

    def add(self, bad, message: Callable[[int], str]) -> None:
        """Refuse the variants where *bad* holds (and that are not refused already)."""
        new = np.broadcast_to(np.asarray(bad, bool), (self.n,)) & ~self.mask
        if new.any():
            self._checks.append((new, message))
            self.mask |= new

    def reason(self, i: int) -> str:
        for bad, message in self._checks:
            if bad[i]:
                return message(i)
        return ""

    def merge(self, other: Refusals, first: bool = False) -> None:
        """Refuse what *other* refuses too, with its reasons (before this one's when *first*)."""
        self.mask |= other.mask
        self._checks = other._checks + self._checks if first else self._checks + other._checks

    def copy(self) -> Refusals:
        out = Refusals(self.n)
        out.mask = self.mask.copy()
        out._checks = list(self._checks)
        return out

    def take(self, i: int) -> Refusals:
        out = Refusals(1)
        for bad, message in self._checks:
            if bad[i]:
                out.add(True, lambda _j, m=message: m(i))
        return out


@dataclass(frozen=True)
class Driver:
    """What balances the loads: a torque on *body* or a force along prismatic joint *joint*."""

    body: str
    kind: str = "torque"  # "torque" | "force"
    joint: str | None = None


@dataclass(frozen=True)
class Linkage:
    """One position of a mechanism with its exact velocities and accelerations.

    ``points`` names the points a problem can refer to (pivots, pins, link ends);
    ``transmission`` is the smallest acute transmission angle in degrees (90 is best);
    ``scale`` is a characteristic length used to make the condition number unit-free.
    """

    kind: str
    bodies: dict[str, Body]
    joints: tuple[Joint, ...]
    points: dict[str, P]
    driver: Driver
    input_body: str
    transmission: float
    scale: float
    lengths: dict[str, float] = field(default_factory=dict)
    refused: Refusals | None = None

    def point_at(self, pos) -> str:
        """The name of the point at *pos* ('' when none)."""
        return next((n for n, q in self.points.items() if same_point(q.pos(), pos, atol=1e-12)), "")

    def with_refusals(self, refused: Refusals) -> Linkage:
        return dataclasses.replace(self, refused=refused)

    def take(self, i: int) -> Linkage:
        """Variant *i* of a batched linkage, with float jets."""
        return Linkage(
            self.kind,
            {n: Body(b.name, b.origin.take(i), take(b.angle, i), b.label) for n, b in self.bodies.items()},
            tuple(take_joint(j, i) for j in self.joints),
            {n: p.take(i) for n, p in self.points.items()},
            self.driver,
            self.input_body,
            _take(self.transmission, i),
            _take(self.scale, i),
            {k: _take(v, i) for k, v in self.lengths.items()},
            self.refused.take(i) if self.refused is not None else None,
        )


@dataclass(frozen=True)
class MassProps:
    """Mass, moment of inertia about the centre of mass, and where that centre lies.

    The centre is *along* the body axis and *across* it (to the left) from the point *at*
    (a point name; the body's origin when empty).
    """

    mass: float = 0.0
    inertia: float = 0.0
    at: str = ""
    along: float = 0.0
    across: float = 0.0


@dataclass(frozen=True)
class Load:
    """An external force (at a point of *body*) and/or a pure torque on *body*.

    ``group`` names the load for superposition. ``force`` is the world vector in N; the point is
    located like a centre of mass: from point *at* (body origin if empty) *along*/*across* the
    body axis. ``relative_angle`` set means the force direction is given relative to the body
    axis: ``force`` then holds (magnitude, angle-from-axis in rad) instead of components.
    """

    group: str
    body: str
    force: tuple[float, float] = (0.0, 0.0)
    torque: float = 0.0
    at: str = ""
    along: float = 0.0
    across: float = 0.0
    relative_angle: bool = False


@dataclass(frozen=True)
class Spot:
    """A point fixed on *body* (``ground`` allowed): from point *at* (body origin if empty) *along*
    and *across* (to the left of) the body axis; the ground's axis is +x and its origin (0, 0)."""

    body: str
    at: str = ""
    along: float = 0.0
    across: float = 0.0

    def take(self, i: int) -> Spot:
        return Spot(self.body, self.at, _take(self.along, i), _take(self.across, i))


@dataclass(frozen=True)
class MotionLoad:
    """A load that depends on the motion, a known load once the kinematics are known.

    ``kind``: ``damper`` (ends P, Q; force on Q −c·(v_Q − v_P)·u and its opposite on P, u the unit
    vector P→Q), ``spring`` (force on Q −k·(|PQ| − free_length)·u and its opposite on P),
    ``rotary_damper`` (couple −c·(ω_body − ω_other) on *body*, its opposite on *other*) or
    ``resistance`` (force of size *coefficient* at P opposing P's velocity). SI throughout.
    """

    group: str
    kind: str
    coefficient: float
    ends: tuple[Spot, ...] = ()
    free_length: float = 0.0
    body: str = ""
    other: str = GROUND

    def take(self, i: int) -> MotionLoad:
        return MotionLoad(
            self.group, self.kind, _take(self.coefficient, i), tuple(e.take(i) for e in self.ends),
            _take(self.free_length, i), self.body, self.other,
        )


@dataclass(frozen=True)
class Analysis:
    """What to include: inertia (d'Alembert) and gravity (vector g in m/s², or None)."""

    dynamic: bool = False
    gravity: tuple[float, float] | None = None
    mass: dict[str, MassProps] = field(default_factory=dict)
    loads: tuple[Load, ...] = ()
    max_condition: float = 1e7
    motion_loads: tuple[MotionLoad, ...] = ()
    points: dict[str, Spot] = field(default_factory=dict)  # points a problem defines on its bodies

    def take(self, i: int) -> Analysis:
        """Variant *i* of a batched analysis."""
        return Analysis(
            self.dynamic,
            None if self.gravity is None else (_take(self.gravity[0], i), _take(self.gravity[1], i)),
            {
                b: MassProps(_take(m.mass, i), _take(m.inertia, i), m.at, _take(m.along, i), _take(m.across, i))
                for b, m in self.mass.items()
            },
            tuple(
                Load(
                    ld.group,
                    ld.body,
                    (_take(ld.force[0], i), _take(ld.force[1], i)),
                    _take(ld.torque, i),
                    ld.at,
                    _take(ld.along, i),
                    _take(ld.across, i),
                    ld.relative_angle,
                )
                for ld in self.loads
            ),
            _take(self.max_condition, i),
            tuple(m.take(i) for m in self.motion_loads),
            {k: p.take(i) for k, p in self.points.items()},
        )


def same_point(p, q, atol: float = 1e-8) -> bool:
    """Whether 2-vectors *p* and *q* coincide, as ``numpy.allclose(p, q, atol=atol)`` decides
    (relative tolerance 1e-5 of *q*), without its cost: figures and keys ask it thousands of times."""
    return (abs(p[0] - q[0]) <= atol + 1e-5 * abs(q[0])) and (abs(p[1] - q[1]) <= atol + 1e-5 * abs(q[1]))


def vec(p: np.ndarray) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
