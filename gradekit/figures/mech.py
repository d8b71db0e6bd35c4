"""Drawing a mechanism position on a canvas: bars, pins, ground pivots, sliders, slots, centres of mass."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from gradekit.figures.canvas import BLACK, LIGHT, Canvas
from gradekit.mechanics.mechanisms import KINDS
from gradekit.mechanics.model import GROUND, Linkage, Prismatic, Revolute

BAR = 5.0  # bar width in points
PIN = 2.6  # pin radius in points
BLOCK = (24.0, 14.0)  # slider block length and height in points
SLOT_BLOCK = (15.0, 9.0)

ToPt = Callable[[np.ndarray], np.ndarray]


def positions(link: Linkage) -> dict[str, np.ndarray]:
    return {k: np.asarray(p.pos(), float) for k, p in link.points.items()}


def mech_extent(link: Linkage, extra: list[np.ndarray] = ()) -> tuple[np.ndarray, np.ndarray]:
    pts = np.array(list(positions(link).values()) + [np.asarray(e, float) for e in extra])
    return pts.min(axis=0), pts.max(axis=0)


def rect(c: np.ndarray, angle: float, length: float, height: float) -> np.ndarray:
    u = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([-u[1], u[0]])
    return np.array([c + u * length / 2 + n * height / 2, c - u * length / 2 + n * height / 2,
                     c - u * length / 2 - n * height / 2, c + u * length / 2 - n * height / 2])


def hatch_line(cv: Canvas, a: np.ndarray, b: np.ndarray, side: np.ndarray, step: float = 4.0,
               depth: float = 4.5) -> None:
    """A ground line a–b with short hatch strokes on *side* (a unit vector)."""
    cv.line([a, b], BLACK, 1.0, z=2.5)
    d = b - a
    n = max(2, int(np.hypot(*d) / step))
    u = d / max(np.hypot(*d), 1e-9)
    segs = []
    for k in range(n + 1):
        p = a + d * k / n
        segs.append([p, p + side * depth - u * depth * 0.8])
    for s in segs:
        cv.line(s, BLACK, 0.6, z=2.5, obstacle=False)
    lo = np.min([a, b, a + side * depth, b + side * depth], axis=0)
    hi = np.max([a, b, a + side * depth, b + side * depth], axis=0)
    cv.boxes.append((lo[0], lo[1], hi[0], hi[1]))


def ground_pivot(cv: Canvas, p: np.ndarray, down: np.ndarray | None = None) -> None:
    """A fixed pivot: a triangle under the pin on a hatched base."""
    d = np.array([0.0, -1.0]) if down is None else down
    n = np.array([-d[1], d[0]])
    base = p + d * 10.0
    cv.polygon([p, base + n * 7.0, base - n * 7.0], "white", BLACK, 1.0, z=3.0)
    hatch_line(cv, base + n * 10.0, base - n * 10.0, d)


def com_marker(cv: Canvas, c: np.ndarray, gid: str, r: float = 3.8) -> None:
    """The centre-of-mass symbol: a circle with two opposite quarters filled."""
    cv.circle(c, r, "white", BLACK, 0.8, z=7.0, gid=gid)
    for a0 in (0.0, math.pi):
        t = np.linspace(a0, a0 + math.pi / 2, 7)
        cv.polygon(np.vstack([c, c + r * np.column_stack([np.cos(t), np.sin(t)])]), BLACK, BLACK, 0.3, z=7.1,
                   obstacle=False)


def draw_linkage(cv: Canvas, link: Linkage, T: ToPt, bodies: set[str] | None = None,
                 ground: bool = True, colour: str = LIGHT) -> dict[str, np.ndarray]:
    """Draw the bodies of *link* (all, or those in *bodies*) and return the points in paper points."""
    pos = positions(link)
    P = {k: T(v) for k, v in pos.items()}
    want = set(link.bodies) if bodies is None else bodies
    kind = KINDS[link.kind]
    bars = kind.bars
    for body, pairs in bars.items():
        if body not in want:
            continue
        for a, b in pairs:
            if a not in P or b not in P:
                continue
            slot = body == kind.slotted
            pa, pb = P[a], P[b]
            if slot:  # the slot runs over the pivot, the far end and the block, whatever their order
                pivot, block, end = kind.slot
                u = (P[block] - P[pivot]) / max(float(np.hypot(*(P[block] - P[pivot]))), 1e-9)
                ts = [0.0, float(np.dot(P[end] - P[pivot], u)), float(np.dot(P[block] - P[pivot], u))]
                ext = SLOT_BLOCK[0] / 2 + 3.0
                lo_t = min(ts) - (ext if min(ts) == ts[2] else 0.0)
                hi_t = max(ts) + (ext if max(ts) == ts[2] else 0.0)
                pa, pb = P[pivot] + u * lo_t, P[pivot] + u * hi_t
            bar(cv, pa, pb, f"link-{body}" if (a, b) == pairs[0] else None, colour, slot)
    # ground line between fixed pivots (frame), thin dash-dot
    fixed = [j.point for j in link.joints if isinstance(j, Revolute) and GROUND in (j.a, j.b)]
    if ground and bodies is None and len(fixed) >= 2:
        a, b = T(np.asarray(fixed[0].pos())), T(np.asarray(fixed[1].pos()))
        cv.line([a, b], BLACK, 0.6, "-.", z=1.0)
    for j in link.joints:
        if isinstance(j, Prismatic):
            c = T(np.asarray(j.point.pos()))
            ang = float(j.axis.v)
            size = BLOCK if j.guide == GROUND else SLOT_BLOCK
            if j.block in want:
                cv.polygon(rect(c, ang, *size), "white", BLACK, 1.2, z=4.0, gid=f"block-{j.block}")
            if j.guide == GROUND and ground and (bodies is None):
                u = np.array([math.cos(ang), math.sin(ang)])
                n = np.array([-u[1], u[0]])
                half = size[1] / 2 + 0.8
                span = size[0] * 1.7
                # the guide goes on the side away from the link that drives the block
                here = [k for k, p in P.items() if float(np.hypot(*(p - c))) < 1e-6]
                ends = [P[b if a in here else a] for pairs in bars.values() for a, b in pairs
                        if (a in here) != (b in here)]
                side = float(np.mean([np.dot(p - c, n) for p in ends])) if ends else 1.0
                for sgn in ((-1.0,) if side > 0 else (1.0,)):
                    a, b = c - u * span + sgn * n * half, c + u * span + sgn * n * half
                    hatch_line(cv, a, b, sgn * n)
    for j in link.joints:
        if not isinstance(j, Revolute):
            continue
        if bodies is not None and j.a not in want and j.b not in want:
            continue
        c = T(np.asarray(j.point.pos()))
        if GROUND in (j.a, j.b) and ground and bodies is None:
            ground_pivot(cv, c)
        cv.circle(c, PIN, "white", BLACK, 1.0, z=8.0)
    return P


def bar(cv: Canvas, a: np.ndarray, b: np.ndarray, gid: str | None, colour: str = LIGHT,
        slot: bool = False) -> None:
    """A link drawn as a rounded bar (outline, then fill; the outline carries *gid*)."""
    w = BAR + (3.0 if slot else 0.0)
    cv.line([a, b], BLACK, w + 1.6, gid=gid, z=2.0)
    cv.line([a, b], colour, w, z=2.1, obstacle=False)
    if slot:
        cv.line([a, b], "white", 2.2, z=2.2, obstacle=False)
