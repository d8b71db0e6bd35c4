"""Frozen records of one mechanism position: bodies, joints, driver, loads and mass properties.

Conventions: SI units (m, kg, s, N, rad) inside the core; angles CCW from +x; torques and
angular rates CCW positive; a revolute joint's unknown is the force of body ``a`` on body ``b``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gradekit.mechanics.jet import Jet, P

GROUND = "ground"


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
class Analysis:
    """What to include: inertia (d'Alembert) and gravity (vector g in m/s², or None)."""

    dynamic: bool = False
    gravity: tuple[float, float] | None = None
    mass: dict[str, MassProps] = field(default_factory=dict)
    loads: tuple[Load, ...] = ()
    max_condition: float = 1e7


def vec(p: np.ndarray) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
