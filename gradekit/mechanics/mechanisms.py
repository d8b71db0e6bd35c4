"""Closed-form position solutions of the course's mechanisms, evaluated on jets, batched.

Each builder takes SI parameters and the input motion (crank angle, speed, acceleration) as
floats or as arrays with one entry per variant, and returns a `Linkage`: every body's frame and
every named point with exact velocity and acceleration, for all variants at once. Branches are
explicit: ``branch=+1`` puts the closing point on the left of the directed line between the two
known points (for a four-bar with the frame along +x and the crank above it, the *open*
configuration), ``-1`` on the right (*crossed*). For sliders, ``+1`` puts the slider ahead of the
driving pin along the slide axis. A variant that cannot be assembled is not an exception but an
entry of the linkage's `Refusals` (a mask and a message per variant); `build` raises for N = 1.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from gradekit.mechanics.errors import GeometryError
from gradekit.mechanics.jet import Jet, P, atan2, sqrt, where
from gradekit.mechanics.model import GROUND, Body, Driver, Linkage, Prismatic, Refusals, Revolute

Fmt = Callable[[float], str]


def _mm(x: float) -> str:
    return f"{x * 1000:.6g} mm"


def _at(x, i: int) -> float:
    return float(x[i]) if np.ndim(x) else float(x)


@dataclass(frozen=True)
class Motion:
    """Input crank angle (rad), angular velocity (rad/s) and angular acceleration (rad/s²).

    Each is a float or an array with one entry per variant.
    """

    theta: float | np.ndarray
    omega: float | np.ndarray = 0.0
    alpha: float | np.ndarray = 0.0

    def jet(self) -> Jet:
        return Jet(self.theta, self.omega, self.alpha)


def circle_point(p1: P, r1, p2: P, r2, branch, names: str, fmt: Fmt, bad: Refusals) -> P:
    """The point at *r1* from *p1* and *r2* from *p2*, on the *branch* side of p1→p2."""
    s = p2 - p1
    dist = s.norm()
    lo, hi = np.abs(r1 - r2), r1 + r2
    bad.add(
        ~((lo * (1 - 1e-12) <= dist.v) & (dist.v <= hi * (1 + 1e-12))),
        lambda i: (
            f"cannot be assembled: {names} are {fmt(_at(r1, i))} and {fmt(_at(r2, i))}, so the distance "
            f"they span must lie between {fmt(_at(lo, i))} and {fmt(_at(hi, i))}, but it is "
            f"{fmt(_at(dist.v, i))}"
        ),
    )
    num = s.dot(s) + r1 * r1 - r2 * r2
    den = dist * (2 * r1)
    disc = den * den - num * num
    # at the exact toggle the half-chord's rate is undefined (0/0): NaN, refused as a toggle below
    half = where(disc.v > 0, sqrt(disc), sqrt(Jet(0.0)))
    gamma = atan2(half, num)
    angle = s.angle() + gamma * branch
    return p1 + P.polar(r1, angle)


def slide_point(pin: P, length, origin: P, axis, offset, branch, names: str, fmt: Fmt, bad: Refusals) -> P:
    """The point at *length* from *pin* on the line at *axis* through *origin* + *offset* (left normal)."""
    u = P.fixed(np.cos(axis), np.sin(axis))
    n = P.fixed(-np.sin(axis), np.cos(axis))
    rel = pin - origin
    along_ = rel.dot(u)
    across = rel.dot(n) * -1 + offset
    disc = across * across * -1 + length * length
    bad.add(
        disc.v < -1e-12 * length * length,
        lambda i: (
            f"cannot be assembled: {names} is {fmt(_at(length, i))} long but the slide line lies "
            f"{fmt(abs(_at(across.v, i)))} from its pin"
        ),
    )
    root = where(disc.v > 0, sqrt(disc), Jet(0.0))
    x = along_ + root * branch
    return origin + u * x + n * offset


def _acute(a: P, b: P):
    """Acute angle in degrees between the lines of two vectors."""
    ang = np.abs(np.degrees(a.angle().v - b.angle().v)) % 180.0
    return np.minimum(ang, 180.0 - ang)


def _rev(name: str, a: str, b: str, pts: dict[str, P]) -> Revolute:
    return Revolute(name, a, b, pts[name])


def _largest(lengths: dict):
    return functools.reduce(np.maximum, [np.abs(v) for v in lengths.values()])


def _o2(p: dict) -> P:
    return P.fixed(p.get("x_O2", 0.0), p.get("y_O2", 0.0))


def single_crank(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals) -> Linkage:
    """One link O2A pinned to the frame and driven: the inertia of a single link (slides 002)."""
    o2 = _o2(p)
    th = m.jet()
    pts = {"O2": o2, "A": o2 + P.polar(p["crank"], th)}
    bodies = {"crank": Body("crank", o2, th)}
    lengths = {"crank": p["crank"]}
    return Linkage(
        "crank", bodies, (_rev("O2", GROUND, "crank", pts),), pts, Driver("crank"), "crank", 90.0, p["crank"], lengths
    )


def fourbar(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals) -> Linkage:
    """Four-bar O2-A-B-O4: crank O2A driven, coupler AB, rocker O4B, frame O2O4 at any angle."""
    o2 = _o2(p)
    fa = p.get("frame_angle", 0.0)
    o4 = o2 + P.fixed(p["frame"] * np.cos(fa), p["frame"] * np.sin(fa))
    th = m.jet()
    a = o2 + P.polar(p["crank"], th)
    b = circle_point(a, p["coupler"], o4, p["rocker"], branch, "coupler AB and rocker O4B", fmt, bad)
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
        "fourbar", bodies, joints, pts, Driver("crank"), "crank", _acute(b - a, b - o4), _largest(lengths), lengths
    )


def slider_crank(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals, driver: str = "crank") -> Linkage:
    """Slider crank O2-A-B: crank O2A, rod AB, slider B on a line at ``slide_angle`` offset by ``offset``."""
    o2 = _o2(p)
    th = m.jet()
    pts = {"O2": o2, "A": o2 + P.polar(p["crank"], th)}
    axis_v = p.get("slide_angle", 0.0)
    pts["B"] = slide_point(pts["A"], p["rod"], o2, axis_v, p.get("offset", 0.0), branch, "the rod from A", fmt, bad)
    axis = Jet(axis_v)
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
    mu = 90.0 - _acute(pts["B"] - pts["A"], u)
    return Linkage("slider_crank", bodies, joints, pts, drv, "crank", mu, _largest(lengths), lengths)


def _slotted(p: dict, m: Motion, bad: Refusals) -> tuple[dict, dict, list]:
    o2 = _o2(p)
    fa = p.get("frame_angle", -np.pi / 2)
    o4 = o2 + P.fixed(p["frame"] * np.cos(fa), p["frame"] * np.sin(fa))
    th = m.jet()
    a = o2 + P.polar(p["crank"], th)
    bad.add(
        np.abs(p["frame"] - p["crank"]) < 1e-9 * np.maximum(p["frame"], p["crank"]),
        lambda i: "cannot be assembled: the crank pin passes through the lever pivot (crank = frame distance O2O4)",
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


def slotted_lever(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals) -> Linkage:
    """Crank and slotted lever (inverted slider crank): a block on crank pin A slides in lever O4C."""
    pts, bodies, joints = _slotted(p, m, bad)
    lengths = {k: p[k] for k in ("crank", "frame", "lever")}
    return Linkage(
        "slotted_lever", bodies, tuple(joints), pts, Driver("crank"), "crank", 90.0, _largest(lengths), lengths
    )


def _add_ram(pts: dict, bodies: dict, joints: list, p: dict, carrier: str, branch, fmt: Fmt, bad: Refusals):
    """Attach link C-D and ram D (sliding on ground) to point C; return the ram transmission angle."""
    axis_v = p.get("slide_angle", 0.0)
    axis = Jet(axis_v)
    pts["D"] = slide_point(pts["C"], p["link"], pts["O4"], axis_v, p["ram_offset"], branch, "the link CD", fmt, bad)
    bodies["link"] = Body("link", pts["C"], (pts["D"] - pts["C"]).angle())
    bodies["ram"] = Body("ram", pts["D"], axis)
    joints += [
        _rev("C", carrier, "link", pts),
        _rev("D", "link", "ram", pts),
        Prismatic("ram_slide", GROUND, "ram", pts["D"], axis),
    ]
    return 90.0 - _acute(pts["D"] - pts["C"], P.polar(1.0, axis))


def quick_return(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals, kind: str = "whitworth") -> Linkage:
    """Whitworth (frame < crank, lever turns fully) or crank-shaper (frame > crank, lever rocks):
    slotted lever O4C, link CD and ram D on a slide line ``ram_offset`` from O4."""
    if kind == "whitworth":
        bad.add(
            ~(np.asarray(p["frame"]) < p["crank"]),
            lambda i: (
                f"not a Whitworth mechanism: the frame O2O4 ({fmt(_at(p['frame'], i))}) must "
                f"be shorter than the crank ({fmt(_at(p['crank'], i))})"
            ),
        )
    else:
        bad.add(
            ~(np.asarray(p["frame"]) > p["crank"]),
            lambda i: (
                f"not a crank-shaper: the frame O2O4 ({fmt(_at(p['frame'], i))}) must be longer than "
                f"the crank ({fmt(_at(p['crank'], i))})"
            ),
        )
    pts, bodies, joints = _slotted(p, m, bad)
    mu = _add_ram(pts, bodies, joints, p, "lever", branch, fmt, bad)
    lengths = {k: p[k] for k in ("crank", "frame", "lever", "link")}
    return Linkage(kind, bodies, tuple(joints), pts, Driver("crank"), "crank", mu, _largest(lengths), lengths)


def fourbar_quick_return(p: dict, m: Motion, branch: int, fmt: Fmt, bad: Refusals) -> Linkage:
    """Crank-rocker four-bar whose rocker, extended to C (``arm`` from O4), drives a ram through link CD."""
    base = fourbar(p, m, branch, fmt, bad)
    pts, bodies, joints = dict(base.points), dict(base.bodies), list(base.joints)
    rocker = bodies["rocker"]
    pts["C"] = rocker.origin + P.polar(p["arm"], rocker.angle)
    mu = _add_ram(pts, bodies, joints, p, "rocker", p.get("ram_branch", 1), fmt, bad)
    lengths = dict(base.lengths, arm=p["arm"], link=p["link"])
    return Linkage(
        "fourbar_quick_return",
        bodies,
        tuple(joints),
        pts,
        Driver("crank"),
        "crank",
        np.minimum(base.transmission, mu),
        _largest(lengths),
        lengths,
    )


Bars = dict[str, tuple[tuple[str, str], ...]]
Segment = tuple[str, str, str]
Loop = tuple[tuple[Segment, ...], tuple[Segment, ...]]


@dataclass(frozen=True)
class Kind:
    """A mechanism type: everything the rest of gradekit knows about it, in one place.

    Attributes:
        build: the builder (SI parameters, motion, branch, formatter, refusals) → `Linkage`.
        required: geometry parameters a problem must give (SI lengths, angles in rad).
        optional: geometry parameters with their defaults.
        bodies: the moving bodies, in the order of the equilibrium equations.
        points: the named points a problem can refer to (and rename with ``points:``).
        drivers: the bodies a problem may drive (``driver:``); the first is the default.
        angles: which geometry parameters are angles (the rest are lengths).
        bars: what a figure draws of each body: segments between named points.
        slotted: the body drawn as a slotted lever ('' for none).
        slot: (pivot, block, end): the slot's line runs from the pivot through the block's pin, over the
            body's far end, wherever the block is along it (for the slotted body).
        signs: geometry parameters that are a choice of side (+1 or -1), neither a length nor an angle.
        dimensions: which segment each geometry length dimensions in a figure.
        loop: the four-bar loop (crank, coupler, rocker, frame) a Grashof constraint reads, if any.
        dead_centre: (pivot, crank pin, slider pin): the crank and rod a dead-centre constraint reads.
    """

    build: Callable[..., Linkage]
    required: tuple[str, ...]
    optional: dict[str, float]
    bodies: tuple[str, ...]
    points: tuple[str, ...]
    drivers: tuple[str, ...] = ("crank",)
    angles: tuple[str, ...] = ()
    bars: Bars = field(default_factory=dict)
    slotted: str = ""
    slot: tuple[str, str, str] | tuple[()] = ()
    signs: tuple[str, ...] = ()
    dimensions: dict[str, tuple[str, str]] = field(default_factory=dict)
    loop: tuple[str, ...] = ()
    dead_centre: tuple[str, str, str] | tuple[()] = ()
    example: dict[str, float] = field(default_factory=dict)  # SI geometry that assembles (starter problems)
    about: str = ""  # what the kind is, its points, and where offsets are measured from
    branch: str = ""  # what branch +1 (open) and -1 (crossed) choose
    # the loop-closure equations a worked key writes: each loop is (left chain, right chain) of
    # segments (from point, to point, the body the segment turns with; a segment whose length
    # changes slides along that body), left sum of vectors = right sum
    closure: tuple[Loop, ...] = ()


_POS = {"x_O2": 0.0, "y_O2": 0.0}
_CRANK = {"crank": (("O2", "A"),)}
_FOURBAR_BARS = {**_CRANK, "coupler": (("A", "B"),), "rocker": (("O4", "B"),)}
_SLOTTED_BARS = {**_CRANK, "lever": (("O4", "C"),)}
_FOURBAR_LOOP: Loop = ((("O2", "A", "crank"), ("A", "B", "coupler")), (("O2", "O4", GROUND), ("O4", "B", "rocker")))
_SLOTTED_LOOP: Loop = ((("O2", "A", "crank"),), (("O2", "O4", GROUND), ("O4", "A", "lever")))
_RAM_LOOP: Loop = ((("O4", "C", "{carrier}"), ("C", "D", "link")), (("O4", "D", GROUND),))


def _ram_loop(carrier: str) -> Loop:
    return tuple(tuple((a, b, c.format(carrier=carrier)) for a, b, c in side) for side in _RAM_LOOP)  # type: ignore[return-value]


_DIMS = {
    "crank": ("O2", "A"),
    "coupler": ("A", "B"),
    "rod": ("A", "B"),
    "rocker": ("O4", "B"),
    "frame": ("O2", "O4"),
    "lever": ("O4", "C"),
    "link": ("C", "D"),
    "arm": ("O4", "C"),
}


def _dims(*names: str) -> dict[str, tuple[str, str]]:
    return {n: _DIMS[n] for n in names}


KINDS: dict[str, Kind] = {
    "crank": Kind(
        single_crank,
        ("crank",),
        dict(_POS),
        ("crank",),
        ("O2", "A"),
        bars=_CRANK,
        dimensions=_dims("crank"),
        example={"crank": 0.1},
        about="One link O2A pinned to the frame at O2 and driven: the inertia force and couple of a single link. "
        "O2 is at (x_O2, y_O2).",
        branch="no closure: branch does not matter.",
    ),
    "fourbar": Kind(
        fourbar,
        ("crank", "coupler", "rocker", "frame"),
        {**_POS, "frame_angle": 0.0},
        ("crank", "coupler", "rocker"),
        ("O2", "A", "B", "O4"),
        angles=("frame_angle",),
        bars=_FOURBAR_BARS,
        dimensions=_dims("crank", "coupler", "rocker", "frame"),
        loop=("crank", "coupler", "rocker", "frame"),
        closure=(_FOURBAR_LOOP,),
        example={"crank": 0.05, "coupler": 0.15, "rocker": 0.12, "frame": 0.14},
        about="Crank O2A, coupler AB and rocker O4B; the frame O2O4 has length `frame` at `frame_angle` from +x "
        "(O2 at (x_O2, y_O2)).",
        branch="open (+1) puts B on the left of the line A→O4 (above the frame for a frame along +x and a "
        "crank above it); crossed (-1) on the right.",
    ),
    "slider_crank": Kind(
        slider_crank,
        ("crank", "rod"),
        {**_POS, "offset": 0.0, "slide_angle": 0.0},
        ("crank", "rod", "slider"),
        ("O2", "A", "B"),
        ("crank", "slider"),
        angles=("slide_angle",),
        bars={**_CRANK, "rod": (("A", "B"),)},
        dimensions=_dims("crank", "rod"),
        dead_centre=("O2", "A", "B"),
        closure=(((("O2", "A", "crank"), ("A", "B", "rod")), (("O2", "B", GROUND),)),),
        example={"crank": 0.05, "rod": 0.2},
        about="Crank O2A, connecting rod AB and slider B. The slide line runs at `slide_angle` from +x; `offset` "
        "is its distance from O2, measured along the slide axis' left normal (for a horizontal slide, "
        "+offset puts the line above O2). Drivers: crank (a torque) or slider (a force along the slide).",
        branch="open (+1) puts the slider ahead of the crank pin A along the slide axis; crossed (-1) behind.",
    ),
    "slotted_lever": Kind(
        slotted_lever,
        ("crank", "frame", "lever"),
        {**_POS, "frame_angle": -np.pi / 2},
        ("crank", "block", "lever"),
        ("O2", "A", "O4", "C"),
        angles=("frame_angle",),
        bars=_SLOTTED_BARS,
        slotted="lever",
        slot=("O4", "A", "C"),
        dimensions=_dims("crank", "frame", "lever"),
        closure=(_SLOTTED_LOOP,),
        example={"crank": 0.1, "frame": 0.2, "lever": 0.4},
        about="Crank O2A; block A slides in the slotted lever O4C (C at `lever` from O4 along O4→A). The lever "
        "pivot O4 is at `frame` from O2 at `frame_angle` (-90°: below O2).",
        branch="no closure choice: branch does not matter.",
    ),
    **{
        name: Kind(
            partial(quick_return, kind=name),
            ("crank", "frame", "lever", "link", "ram_offset"),
            {**_POS, "frame_angle": -np.pi / 2, "slide_angle": 0.0},
            ("crank", "block", "lever", "link", "ram"),
            ("O2", "A", "O4", "C", "D"),
            angles=("frame_angle", "slide_angle"),
            bars={**_SLOTTED_BARS, "link": (("C", "D"),)},
            slotted="lever",
            slot=("O4", "A", "C"),
            dimensions=_dims("crank", "frame", "lever", "link"),
            closure=(_SLOTTED_LOOP, _ram_loop("lever")),
            example=(
                {"crank": 0.1, "frame": 0.05, "lever": 0.15, "link": 0.25, "ram_offset": 0.05}
                if name == "whitworth"
                else {"crank": 0.1, "frame": 0.3, "lever": 0.5, "link": 0.2, "ram_offset": 0.5}
            ),
            about=(
                "Crank O2A; block A slides in lever O4C (C at `lever` from O4 along O4→A; a negative lever puts C "
                "on the other side of O4); link CD; ram D on a slide line at `slide_angle`, `ram_offset` from O4 "
                "along the slide axis' left normal. O4 is at `frame` from O2 at `frame_angle` (-90°: below O2). "
                + ("Whitworth: frame < crank, the lever turns fully." if name == "whitworth"
                   else "Crank shaper: frame > crank, the lever rocks.")
            ),
            branch="open (+1) puts the ram D ahead of C along the slide axis; crossed (-1) behind.",
        )
        for name in ("whitworth", "crank_shaper")
    },
    "fourbar_quick_return": Kind(
        fourbar_quick_return,
        ("crank", "coupler", "rocker", "frame", "arm", "link", "ram_offset"),
        {**_POS, "frame_angle": 0.0, "slide_angle": 0.0, "ram_branch": 1.0},
        ("crank", "coupler", "rocker", "link", "ram"),
        ("O2", "A", "B", "O4", "C", "D"),
        angles=("frame_angle", "slide_angle"),
        signs=("ram_branch",),
        bars={**_FOURBAR_BARS, "rocker": (("O4", "B"), ("O4", "C")), "link": (("C", "D"),)},
        dimensions=_dims("crank", "coupler", "rocker", "frame", "arm", "link"),
        loop=("crank", "coupler", "rocker", "frame"),
        closure=(_FOURBAR_LOOP, _ram_loop("rocker")),
        example={"crank": 0.05, "coupler": 0.15, "rocker": 0.12, "frame": 0.14, "arm": 0.2, "link": 0.2,
                 "ram_offset": 0.25},
        about="A crank-rocker four-bar (as fourbar) whose rocker, extended to C at `arm` from O4 along O4→B, "
        "drives link CD and ram D on a slide line at `slide_angle`, `ram_offset` from O4 along the slide axis' "
        "left normal.",
        branch="branch chooses the four-bar's closure (as fourbar); ram_branch +1 puts D ahead of C along the "
        "slide axis, -1 behind.",
    ),
}
ANGLE_PARAMS = frozenset(a for k in KINDS.values() for a in k.angles)


@functools.cache
def _carriers(kind: str) -> tuple[tuple[str, tuple[str, ...]], ...]:
    spec = KINDS[kind]
    link = build(kind, spec.example, Motion(np.radians(60.0), 10.0))
    out: dict[str, list[str]] = {p: [] for p in spec.points}

    def at(name: str, q: P) -> bool:
        return bool(np.hypot(*(link.points[name].pos() - q.pos())) < 1e-9 * link.scale)

    for name in spec.points:
        for j in link.joints:
            if isinstance(j, Revolute) and at(name, j.point):
                out[name] += [j.a, j.b]
        for body, b in link.bodies.items():
            if at(name, b.origin) or any(name in seg for seg in spec.bars.get(body, ())):
                out[name].append(body)
    order = (GROUND, *spec.bodies)
    return tuple((p, tuple(b for b in order if b in bs)) for p, bs in out.items())


@functools.cache
def joint_pairs(kind: str) -> frozenset[tuple[str, str]]:
    """Every pair of bodies a joint of *kind* joins (both orders): where ``F[i,j]`` exists."""
    link = build(kind, KINDS[kind].example, Motion(np.radians(60.0), 10.0))
    pairs = [(j.a, j.b) if isinstance(j, Revolute) else (j.guide, j.block) for j in link.joints]
    return frozenset(pairs + [(b, a) for a, b in pairs])


def carriers(kind: str) -> dict[str, tuple[str, ...]]:
    """The bodies each of a kind's points is fixed on (``ground`` for a fixed pivot), read from the
    kind's example position: its pins, body origins and drawing bars."""
    return dict(_carriers(kind))


def build_many(
    kind: str,
    params: dict,
    motion: Motion,
    branch: int = 1,
    fmt: Fmt = _mm,
    driver: str = "crank",
    n: int | None = None,
) -> Linkage:
    """Build mechanism *kind* for every variant at once (parameters and motion: floats or arrays).

    Variants that cannot be assembled, or whose motion is undefined (a toggle), are refused in
    the returned linkage's ``refused`` (mask and reasons); their numbers are meaningless.
    """
    spec = KINDS[kind]
    full = {**spec.optional, **params}
    if n is None:
        n = int(np.broadcast(*(np.asarray(v) for v in (*full.values(), motion.theta, motion.omega, motion.alpha))).size)
    bad = Refusals(n)
    with np.errstate(all="ignore"):
        # a kind with a choice of driver (the slider crank: crank or slider) is told which one drives
        chosen = {"driver": driver} if len(spec.drivers) > 1 else {}
        link = spec.build(full, motion, branch, fmt, bad, **chosen)
        for name, pt in link.points.items():
            finite = np.ones(n, bool)
            for c in (pt.x, pt.y):
                for v in (c.v, c.d, c.dd):
                    finite &= np.isfinite(v)
            bad.add(
                ~finite,
                lambda i, name=name: (
                    f"at a limit (toggle) position: the motion of point {name} is not defined there; "
                    "choose another crank angle"
                ),
            )
    return link.with_refusals(bad)


def build(kind: str, params: dict, motion: Motion, branch: int = 1, fmt: Fmt = _mm, driver: str = "crank") -> Linkage:
    """Build one position of mechanism *kind* (scalar parameters); raises `GeometryError`."""
    link = build_many(kind, params, motion, branch, fmt, driver, n=1)
    if link.refused.mask[0]:
        raise GeometryError(link.refused.reason(0))
    return link.take(0)
