"""Closed-form position solutions of the course's mechanisms, evaluated on jets.

Each builder takes SI parameters and the input motion (crank angle, speed, acceleration) and
returns a `Linkage`: every body's frame and every named point with exact velocity and
acceleration. Branches are explicit: ``branch=+1`` puts the closing point on the left of the
directed line between the two known points (for a four-bar with the frame along +x and the crank
above it, the *open* configuration), ``-1`` on the right (*crossed*). For sliders, ``+1`` puts the
slider ahead of the driving pin along the slide axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from gradekit.errors import GeometryError
from gradekit.mechanics.jet import Jet, P, atan2, sqrt
from gradekit.mechanics.model import GROUND, Body, Driver, Linkage, Prismatic, Revolute

Fmt = Callable[[float], str]


def _mm(x: float) -> str:
    return f"{x * 1000:.6g} mm"


@dataclass(frozen=True)
class Motion:
    """Input crank angle (rad), angular velocity (rad/s) and angular acceleration (rad/s²)."""

    theta: float
    omega: float = 0.0
    alpha: float = 0.0

    def jet(self) -> Jet:
        return Jet(self.theta, self.omega, self.alpha)


def circle_point(p1: P, r1: float, p2: P, r2: float, branch: int, names: str, fmt: Fmt) -> P:
    """The point at *r1* from *p1* and *r2* from *p2*, on the *branch* side of p1→p2."""
    s = p2 - p1
    dist = s.norm()
    lo, hi = abs(r1 - r2), r1 + r2
    if not (lo * (1 - 1e-12) <= dist.v <= hi * (1 + 1e-12)):
        raise GeometryError(
            f"cannot be assembled: {names} are {fmt(r1)} and {fmt(r2)}, so the distance they "
            f"span must lie between {fmt(lo)} and {fmt(hi)}, but it is {fmt(float(dist.v))}"
        )
    num = s.dot(s) + r1 * r1 - r2 * r2
    den = dist * (2 * r1)
    half = sqrt(Jet.lift(den * den - num * num) if (den * den - num * num).v > 0 else Jet(0.0))
    gamma = atan2(half, num)
    angle = s.angle() + gamma * branch
    return p1 + P.polar(r1, angle)


def slide_point(pin: P, length: float, origin: P, axis: float, offset: float, branch: int, names: str, fmt: Fmt) -> P:
    """The point at *length* from *pin* on the line at *axis* through *origin* + *offset* (left normal)."""
    u = P.fixed(math.cos(axis), math.sin(axis))
    n = P.fixed(-math.sin(axis), math.cos(axis))
    rel = pin - origin
    along_ = rel.dot(u)
    across = rel.dot(n) * -1 + offset
    disc = across * across * -1 + length * length
    if disc.v < -1e-12 * length * length:
        raise GeometryError(
            f"cannot be assembled: {names} is {fmt(length)} long but the slide line lies "
            f"{fmt(abs(float(across.v)))} from its pin"
        )
    root = sqrt(disc) if disc.v > 0 else Jet(0.0)
    x = along_ + root * branch
    return origin + u * x + n * offset


def _acute(a: P, b: P) -> float:
    """Acute angle in degrees between the lines of two vectors."""
    ang = abs(math.degrees(float(a.angle().v - b.angle().v))) % 180.0
    return min(ang, 180.0 - ang)


def _rev(name: str, a: str, b: str, pts: dict[str, P]) -> Revolute:
    return Revolute(name, a, b, pts[name])


def single_crank(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm) -> Linkage:
    """One link O2A pinned to the frame and driven: the inertia of a single link (slides 002)."""
    o2 = P.fixed(p.get("x_O2", 0.0), p.get("y_O2", 0.0))
    th = m.jet()
    pts = {"O2": o2, "A": o2 + P.polar(p["crank"], th)}
    bodies = {"crank": Body("crank", o2, th)}
    return Linkage(
        "crank",
        bodies,
        (_rev("O2", GROUND, "crank", pts),),
        pts,
        Driver("crank"),
        "crank",
        90.0,
        p["crank"],
        {"crank": p["crank"]},
    )


def fourbar(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm) -> Linkage:
    """Four-bar O2-A-B-O4: crank O2A driven, coupler AB, rocker O4B, frame O2O4 at any angle."""
    o2 = P.fixed(p.get("x_O2", 0.0), p.get("y_O2", 0.0))
    o4 = o2 + P.fixed(
        p["frame"] * math.cos(p.get("frame_angle", 0.0)), p["frame"] * math.sin(p.get("frame_angle", 0.0))
    )
    th = m.jet()
    a = o2 + P.polar(p["crank"], th)
    b = circle_point(a, p["coupler"], o4, p["rocker"], branch, "coupler AB and rocker O4B", fmt)
    pts = {"O2": o2, "A": a, "B": b, "O4": o4}
    bodies = {
        "crank": Body("crank", o2, th),
        "coupler": Body("coupler", a, (b - a).angle()),
        "rocker": Body("rocker", o4, (b - o4).angle()),
    }
    joints = (
        _rev("O2", GROUND, "crank", pts),
        _rev("A", "crank", "coupler", pts),
        _rev("B", "coupler", "rocker", pts),
        _rev("O4", GROUND, "rocker", pts),
    )
    lengths = {k: p[k] for k in ("crank", "coupler", "rocker", "frame")}
    return Linkage(
        "fourbar", bodies, joints, pts, Driver("crank"), "crank", _acute(b - a, b - o4), max(lengths.values()), lengths
    )


def _ram(pts: dict, pin: str, p: dict, origin: P, branch: int, fmt: Fmt, rod: str) -> P:
    axis = p.get("slide_angle", 0.0)
    return slide_point(pts[pin], p[rod], origin, axis, p.get("offset", 0.0), branch, f"the {rod} from {pin}", fmt)


def slider_crank(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm, driver: str = "crank") -> Linkage:
    """Slider crank O2-A-B: crank O2A, rod AB, slider B on a line at ``slide_angle`` offset by ``offset``."""
    o2 = P.fixed(p.get("x_O2", 0.0), p.get("y_O2", 0.0))
    th = m.jet()
    pts = {"O2": o2, "A": o2 + P.polar(p["crank"], th)}
    pts["B"] = _ram(pts, "A", p, o2, branch, fmt, "rod")
    axis = Jet(p.get("slide_angle", 0.0))
    bodies = {
        "crank": Body("crank", o2, th),
        "rod": Body("rod", pts["A"], (pts["B"] - pts["A"]).angle()),
        "slider": Body("slider", pts["B"], axis),
    }
    joints = (
        _rev("O2", GROUND, "crank", pts),
        _rev("A", "crank", "rod", pts),
        _rev("B", "rod", "slider", pts),
        Prismatic("slide", GROUND, "slider", pts["B"], axis),
    )
    drv = Driver("crank") if driver == "crank" else Driver("slider", "force", "slide")
    u = P.polar(1.0, axis)
    lengths = {k: p[k] for k in ("crank", "rod")}
    return Linkage(
        "slider_crank",
        bodies,
        joints,
        pts,
        drv,
        "crank",
        90.0 - _acute(pts["B"] - pts["A"], u),
        max(lengths.values()),
        lengths,
    )


def _slotted(p: dict, m: Motion) -> tuple[dict, dict, list]:
    o2 = P.fixed(p.get("x_O2", 0.0), p.get("y_O2", 0.0))
    fa = p.get("frame_angle", -math.pi / 2)
    o4 = o2 + P.fixed(p["frame"] * math.cos(fa), p["frame"] * math.sin(fa))
    th = m.jet()
    a = o2 + P.polar(p["crank"], th)
    if abs(p["frame"] - p["crank"]) < 1e-9 * max(p["frame"], p["crank"]):
        raise GeometryError(
            "cannot be assembled: the crank pin passes through the lever pivot (crank = frame distance O2O4)"
        )
    lever_angle = (a - o4).angle()
    pts = {"O2": o2, "A": a, "O4": o4, "C": o4 + P.polar(p["lever"], lever_angle)}
    bodies = {
        "crank": Body("crank", o2, th),
        "block": Body("block", a, lever_angle),
        "lever": Body("lever", o4, lever_angle),
    }
    joints = [
        _rev("O2", GROUND, "crank", pts),
        _rev("A", "crank", "block", pts),
        Prismatic("slot", "lever", "block", a, lever_angle),
        _rev("O4", GROUND, "lever", pts),
    ]
    return pts, bodies, joints


def slotted_lever(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm) -> Linkage:
    """Crank and slotted lever (inverted slider crank): a block on crank pin A slides in lever O4C."""
    pts, bodies, joints = _slotted(p, m)
    lengths = {k: p[k] for k in ("crank", "frame", "lever")}
    return Linkage(
        "slotted_lever", bodies, tuple(joints), pts, Driver("crank"), "crank", 90.0, max(lengths.values()), lengths
    )


def _add_ram(pts: dict, bodies: dict, joints: list, p: dict, origin: P, branch: int, fmt: Fmt) -> float:
    """Attach link C-D and ram D (sliding on ground) to point C; return the ram transmission angle."""
    axis = Jet(p.get("slide_angle", 0.0))
    pts["D"] = slide_point(pts["C"], p["link"], origin, axis.v, p["ram_offset"], branch, "the link CD", fmt)
    bodies["link"] = Body("link", pts["C"], (pts["D"] - pts["C"]).angle())
    bodies["ram"] = Body("ram", pts["D"], axis)
    joints += [
        _rev("C", "lever", "link", pts),
        _rev("D", "link", "ram", pts),
        Prismatic("ram_slide", GROUND, "ram", pts["D"], axis),
    ]
    return 90.0 - _acute(pts["D"] - pts["C"], P.polar(1.0, axis))


def quick_return(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm, kind: str = "whitworth") -> Linkage:
    """Whitworth (frame < crank, lever turns fully) or crank-shaper (frame > crank, lever rocks):
    slotted lever O4C, link CD and ram D on a slide line ``ram_offset`` from O4."""
    if kind == "whitworth" and not p["frame"] < p["crank"]:
        raise GeometryError(
            f"not a Whitworth mechanism: the frame O2O4 ({fmt(p['frame'])}) must "
            f"be shorter than the crank ({fmt(p['crank'])})"
        )
    if kind == "crank_shaper" and not p["frame"] > p["crank"]:
        raise GeometryError(
            f"not a crank-shaper: the frame O2O4 ({fmt(p['frame'])}) must be longer than the crank ({fmt(p['crank'])})"
        )
    pts, bodies, joints = _slotted(p, m)
    mu = _add_ram(pts, bodies, joints, p, pts["O4"], branch, fmt)
    lengths = {k: p[k] for k in ("crank", "frame", "lever", "link")}
    return Linkage(
        kind, bodies, tuple(joints), pts, Driver("crank"), "crank", mu, max(abs(v) for v in lengths.values()), lengths
    )


def fourbar_quick_return(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm) -> Linkage:
    """Crank-rocker four-bar whose rocker, extended to C (``arm`` from O4), drives a ram through link CD."""
    base = fourbar(p, m, branch, fmt)
    pts, bodies, joints = dict(base.points), dict(base.bodies), list(base.joints)
    rocker = bodies["rocker"]
    pts["C"] = rocker.origin + P.polar(p["arm"], rocker.angle)
    axis = Jet(p.get("slide_angle", 0.0))
    pts["D"] = slide_point(
        pts["C"], p["link"], pts["O4"], axis.v, p["ram_offset"], p.get("ram_branch", 1), "the link CD", fmt
    )
    bodies["link"] = Body("link", pts["C"], (pts["D"] - pts["C"]).angle())
    bodies["ram"] = Body("ram", pts["D"], axis)
    joints += [
        _rev("C", "rocker", "link", pts),
        _rev("D", "link", "ram", pts),
        Prismatic("ram_slide", GROUND, "ram", pts["D"], axis),
    ]
    mu = min(base.transmission, 90.0 - _acute(pts["D"] - pts["C"], P.polar(1.0, axis)))
    lengths = dict(base.lengths, arm=p["arm"], link=p["link"])
    return Linkage(
        "fourbar_quick_return",
        bodies,
        tuple(joints),
        pts,
        Driver("crank"),
        "crank",
        mu,
        max(abs(v) for v in lengths.values()),
        lengths,
    )


def _quick_return_kind(p: dict, m: Motion, branch: int = 1, fmt: Fmt = _mm, *, kind: str) -> Linkage:
    return quick_return(p, m, branch, fmt, kind)


@dataclass(frozen=True)
class Kind:
    """A mechanism type: its builder, required and optional parameters (SI), and its bodies."""

    build: Callable[..., Linkage]
    required: tuple[str, ...]
    optional: dict[str, float]
    bodies: tuple[str, ...]
    points: tuple[str, ...]
    drivers: tuple[str, ...] = ("crank",)


_POS = {"x_O2": 0.0, "y_O2": 0.0}
KINDS: dict[str, Kind] = {
    "crank": Kind(single_crank, ("crank",), dict(_POS), ("crank",), ("O2", "A")),
    "fourbar": Kind(
        fourbar,
        ("crank", "coupler", "rocker", "frame"),
        {**_POS, "frame_angle": 0.0},
        ("crank", "coupler", "rocker"),
        ("O2", "A", "B", "O4"),
    ),
    "slider_crank": Kind(
        slider_crank,
        ("crank", "rod"),
        {**_POS, "offset": 0.0, "slide_angle": 0.0},
        ("crank", "rod", "slider"),
        ("O2", "A", "B"),
        ("crank", "slider"),
    ),
    "slotted_lever": Kind(
        slotted_lever,
        ("crank", "frame", "lever"),
        {**_POS, "frame_angle": -math.pi / 2},
        ("crank", "block", "lever"),
        ("O2", "A", "O4", "C"),
    ),
    **{
        name: Kind(
            partial(_quick_return_kind, kind=name),
            ("crank", "frame", "lever", "link", "ram_offset"),
            {**_POS, "frame_angle": -math.pi / 2, "slide_angle": 0.0},
            ("crank", "block", "lever", "link", "ram"),
            ("O2", "A", "O4", "C", "D"),
        )
        for name in ("whitworth", "crank_shaper")
    },
    "fourbar_quick_return": Kind(
        fourbar_quick_return,
        ("crank", "coupler", "rocker", "frame", "arm", "link", "ram_offset"),
        {**_POS, "frame_angle": 0.0, "slide_angle": 0.0, "ram_branch": 1.0},
        ("crank", "coupler", "rocker", "link", "ram"),
        ("O2", "A", "B", "O4", "C", "D"),
    ),
}


def build(kind: str, params: dict, motion: Motion, branch: int = 1, fmt: Fmt = _mm, driver: str = "crank") -> Linkage:
    """Build one position of mechanism *kind*; raises `GeometryError` when it cannot assemble."""
    spec = KINDS[kind]
    full = {**spec.optional, **params}
    with np.errstate(all="ignore"):
        if kind == "slider_crank":
            link = slider_crank(full, motion, branch, fmt, driver)
        else:
            link = spec.build(full, motion, branch, fmt)
    for name, pt in link.points.items():
        vals = (pt.x.v, pt.y.v, pt.x.d, pt.y.d, pt.x.dd, pt.y.dd)
        if not all(math.isfinite(float(v)) for v in vals):
            raise GeometryError(
                f"at a limit (toggle) position: the motion of point {name} is "
                "not defined there; choose another crank angle"
            )
    return link
