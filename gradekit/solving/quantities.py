"""The answer quantities a problem can ask for (the ``of:`` grammar), one row each, with their producers.

A row states the quantity's name, what goes in its brackets, its SI unit (of the value, or of each
component of a vector), whether it is a vector (``.x``, ``.y``, ``.mag``, ``.angle``), its answer
kind (which measured tolerance default applies), how people read it, its stage on a student's route
and its producer: the function that, given a solved batch (`gradekit.solving.answers.Solved`), puts
the quantity's named results, each a callable so nothing is computed before a problem asks for it.
Rows read together share one producer (a family: the force unknowns, a body's motion and inertia, a
point's motion, the frame's reaction) so that one joint's, body's or point's results stay together.
Validation (`gradekit.bank.schema`), the producer loop (`gradekit.solving.answers.flat_results`: each
producer once, in the order of its first row), the tolerance defaults
(`gradekit.solving.tolerances.answer_kind`), carried-forward credit (`gradekit.solving.carry`: a row's
stage) and the documentation read this table. A new quantity is one row and its producer, here.

Any quantity may carry ``@group`` (one superposition part: a load's name, ``gravity`` or
``inertia[k]``) before its component.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from gradekit.solving.answers import Solved


@dataclass(frozen=True)
class Quantity:
    """One answer quantity of the ``of:`` grammar."""

    name: str
    brackets: str  # what goes in [..]: "i,j" (two link labels), "k" (a link label), "P" (a point), "" (none)
    si: str
    vector: bool
    kind: str  # force, torque, kinematic, length, angle (vector components of forces: force-component);
    # "" where the answer's unit decides (the driver is a torque or a force; a parameter is anything)
    means: str
    # where the quantity stands in the route a student takes (carried-forward credit follows it):
    # given → kinematics → inertia → forces
    stage: str
    # puts the quantity's named results for a solved batch (SI, lazily); rows of a family share it
    produce: Callable[[Solved], None]


# --- the producers: each puts its rows' results, named as `name_of` names them ---------------------


def _force_unknowns(s: Solved) -> None:
    """driver, F and M: the force analysis' unknowns, in total and per superposition part (``@group``);
    at each joint both directions (F[i,j] = −F[j,i]), at a sliding joint the normal force along the
    slide's normal and the couple."""
    lab, put, vector, arr = s.label, s.put, s.vector, s.arr
    link, sol = s.link, s.sol
    drv_unit = BY_NAME["driver"].si if link.driver.kind == "torque" else BY_NAME["F"].si
    put("driver", (sol.driver, drv_unit))
    for suffix, x in s.groups:
        if suffix:
            put("driver" + suffix, (x[:, -1], drv_unit))
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
                put(f"M[{lab(a)},{lab(b)}]{suffix}", (c, BY_NAME["M"].si))
                put(f"M[{lab(b)},{lab(a)}]{suffix}", lambda c=c: (-c, BY_NAME["M"].si))
            else:
                fx, fy, a, b = u[:, 0], u[:, 1], j.a, j.b
            vector(f"F[{lab(a)},{lab(b)}]{suffix}", fx, fy, BY_NAME["F"].si)
            vector(f"F[{lab(b)},{lab(a)}]{suffix}", _neg(fx), _neg(fy), BY_NAME["F"].si)


def _transmission(s: Solved) -> None:
    """The transmission angle the linkage reports."""
    s.put("transmission", (s.arr(s.link.transmission), BY_NAME["transmission"].si))


def _bodies(s: Solved) -> None:
    """theta, omega, alpha, aG, vG, Fi, Ci and h of every moving body, one body after another."""
    put, vector, arr, wrap, n = s.put, s.vector, s.arr, s.wrap, s.n
    for name, st in s.sol.states.items():
        L = s.label(name)
        g = np.broadcast_to(st.a_g, (n, 2))
        v = np.broadcast_to(st.v_g, (n, 2))
        put(f"theta[{L}]", lambda st=st: (wrap(np.degrees(arr(st.angle))), BY_NAME["theta"].si))
        put(f"omega[{L}]", (arr(st.omega), BY_NAME["omega"].si))
        put(f"alpha[{L}]", (arr(st.alpha), BY_NAME["alpha"].si))
        vector(f"aG[{L}]", g[:, 0], g[:, 1], BY_NAME["aG"].si)
        vector(f"vG[{L}]", v[:, 0], v[:, 1], BY_NAME["vG"].si)

        def fi(k, st=st):
            return lambda: np.broadcast_to(st.inertia_force, (n, 2))[:, k]

        vector(f"Fi[{L}]", fi(0), fi(1), BY_NAME["Fi"].si)
        put(f"Ci[{L}]", lambda st=st: (arr(st.inertia_couple), BY_NAME["Ci"].si))
        put(f"h[{L}]", lambda st=st: (np.nan_to_num(arr(st.offset), posinf=0.0, neginf=0.0), BY_NAME["h"].si))


def _points(s: Solved) -> None:
    """v, a and r of every named point (the mechanism's and the problem's own), one point after another;
    r from the problem's origin."""
    vector, origin = s.vector, s.origin

    def comp(pt, attr, axis, sub=None):
        def get():
            p = pt() if callable(pt) else pt
            v = getattr(p.x if axis == 0 else p.y, attr)
            return v - (sub()[axis] if sub else 0.0)

        return get

    for pname, pt in s.points().items():
        P = s.problem.point(pname)
        vector(f"v[{P}]", comp(pt, "d", 0), comp(pt, "d", 1), BY_NAME["v"].si)
        vector(f"a[{P}]", comp(pt, "dd", 0), comp(pt, "dd", 1), BY_NAME["a"].si)
        vector(f"r[{P}]", comp(pt, "v", 0, origin), comp(pt, "v", 1, origin), BY_NAME["r"].si)


def _parameters(s: Solved) -> None:
    """param[name]: the parameter's own value, in its unit, for each answer that asks for one."""
    values, parameters = s.values, s.problem.parameters
    if values is None:
        return
    for spec in s.problem.answers:
        if spec.of.startswith("param["):
            name = spec.of[6:-1]
            s.put(spec.of, lambda name=name: (values[name], parameters[name].unit))


def _frame_reaction(s: Solved) -> None:
    """shaking and shaking_moment, in total and per superposition part: one frame reaction each,
    computed on the first read of either."""
    for suffix, x in s.groups:
        react = s.frame_reaction(x)
        s.vector(f"shaking{suffix}", lambda r=react: r()[0][:, 0], lambda r=react: r()[0][:, 1], BY_NAME["shaking"].si)
        s.put(f"shaking_moment{suffix}", lambda r=react: (r()[1], BY_NAME["shaking_moment"].si))


def _neg(x):
    return (lambda: -x()) if callable(x) else -x


QUANTITIES: tuple[Quantity, ...] = (
    Quantity(
        "driver", "", "N*m", False, "", "the driving torque (or force, for a slider driver)", "forces", _force_unknowns
    ),
    Quantity(
        "transmission", "", "deg", False, "angle", "the smallest acute transmission angle", "kinematics", _transmission
    ),
    Quantity("F", "i,j", "N", True, "force", "the force of link i on link j at their joint", "forces", _force_unknowns),
    Quantity(
        "M", "i,j", "N*m", False, "torque", "the couple of link i on link j at a sliding joint", "forces",
        _force_unknowns,
    ),
    Quantity(
        "aG", "k", "m/s**2", True, "kinematic", "the acceleration of link k's centre of mass", "kinematics", _bodies
    ),
    Quantity("vG", "k", "m/s", True, "kinematic", "the velocity of link k's centre of mass", "kinematics", _bodies),
    Quantity("Fi", "k", "N", True, "force", "the inertia force −m·a_G of link k", "inertia", _bodies),
    Quantity("a", "P", "m/s**2", True, "kinematic", "the acceleration of point P", "kinematics", _points),
    Quantity("v", "P", "m/s", True, "kinematic", "the velocity of point P", "kinematics", _points),
    Quantity(
        "alpha", "k", "rad/s**2", False, "kinematic", "the angular acceleration of link k (CCW +)", "kinematics",
        _bodies,
    ),
    Quantity(
        "omega", "k", "rad/s", False, "kinematic", "the angular velocity of link k (CCW +)", "kinematics", _bodies
    ),
    Quantity("theta", "k", "deg", False, "angle", "the angle of link k, CCW from +x", "kinematics", _bodies),
    Quantity("Ci", "k", "N*m", False, "torque", "the inertia couple −I·α of link k", "inertia", _bodies),
    Quantity(
        "h", "k", "m", False, "length", "the offset I·α/(m·a_G) of link k's equivalent inertia force", "inertia",
        _bodies,
    ),
    Quantity("param", "name", "", False, "", "a parameter's own value (in its unit)", "given", _parameters),
    Quantity(
        "r", "P", "m", True, "length", "the position of point P from the problem's origin", "kinematics", _points
    ),
    Quantity(
        "shaking", "", "N", True, "force",
        "the shaking force: the sum of the forces the mechanism exerts on the frame (ground pins, slides, the "
        "driver's reaction)", "forces", _frame_reaction,
    ),
    Quantity(
        "shaking_moment", "", "N*m", False, "torque",
        "the shaking moment about the origin of those forces, with the guides' couples and the driving "
        "torque's reaction (CCW +)", "forces", _frame_reaction,
    ),
)
BY_NAME = {q.name: q for q in QUANTITIES}
# each producer once, in the order of its first row (so a family's results come where its first row stands)
PRODUCERS: tuple[Callable[[Solved], None], ...] = tuple(dict.fromkeys(q.produce for q in QUANTITIES))
COMPONENTS = ("x", "y", "mag", "angle")

_BRACKETS = {"i,j": r"[^,\]]+,[^\]]+", "k": r"[^\]]+", "P": r"[^\]]+", "name": r"[A-Za-z_][A-Za-z0-9_]*"}
_GRAMMAR = re.compile(
    r"^(?P<name>[A-Za-z_]+)(\[(?P<args>[^\]]*)\])?(@(?P<group>[^.]+))?(\.(?P<component>[a-z]+))?$"
)


@dataclass(frozen=True)
class Asked:
    """An ``of:`` text, parsed: its quantity, bracket text, superposition group and component."""

    quantity: Quantity
    args: str
    group: str
    component: str

    @property
    def kind(self) -> str:
        """The answer kind: vector components of forces are ``force-component``; angles ``angle``;
        "" where the answer's unit decides."""
        if self.component == "angle":
            return "angle"
        if self.quantity.kind == "force" and self.component in ("x", "y"):
            return "force-component"
        return self.quantity.kind

    @property
    def si(self) -> str:
        return "deg" if self.component == "angle" else self.quantity.si


def parse(of: str) -> Asked | None:
    """The quantity an ``of:`` text asks for, or None when the text is not in the grammar."""
    m = _GRAMMAR.match(of.strip()) if isinstance(of, str) else None
    if not m:
        return None
    q = BY_NAME.get(m["name"])
    if q is None:
        return None
    args = m["args"]
    if q.brackets:
        if args is None or not re.fullmatch(_BRACKETS[q.brackets], args):
            return None
    elif args is not None:
        return None
    component = m["component"] or ""
    if component and (not q.vector or component not in COMPONENTS):
        return None
    if q.name == "param" and (m["group"] or component):
        return None
    return Asked(q, args or "", m["group"] or "", component)


def name_of(asked: Asked) -> str:
    """The result name `gradekit.solving.answers.flat_results` registers for *asked* (component included)."""
    stem = asked.quantity.name + (f"[{asked.args}]" if asked.quantity.brackets else "")
    return stem + (f"@{asked.group}" if asked.group else "") + (f".{asked.component}" if asked.component else "")


def grammar() -> str:
    """One line per quantity, for error messages and documentation."""
    rows = []
    for q in QUANTITIES:
        stem = q.name + (f"[{q.brackets}]" if q.brackets else "")
        rows.append(stem + ("[.x|.y|.mag|.angle]" if q.vector else "") + f": {q.means}")
    return "; ".join(rows)


# A derived answer: an expression over results and parameters (``-driver``,
# ``along(F[2,3], 3)``, ``hypot(F[1,2].x, F[1,2].y)``). Results are referred to as in ``of:``;
# ``along(V, k)`` / ``perp(V, k)`` are the components of vector result V along link k's axis and
# along its left normal.
_REF = r"[A-Za-z_][A-Za-z0-9_]*(?:\[[^\]]*\])?(?:@[A-Za-z0-9_]+(?:\[[^\]]*\])?)?(?:\.(?:x|y|mag|angle))?"
_PROJ = re.compile(r"\b(along|perp)\(\s*(" + _REF + r")\s*,\s*([^(),]+?)\s*\)")
_NAME = re.compile(r"(?<![A-Za-z0-9_.\]])" + _REF)
PROJECTIONS = ("along", "perp")


@dataclass(frozen=True)
class Derived:
    """A derived answer: *text* is an expression (for `gradekit.bank.expr`) over parameter names and
    the placeholders of *refs* (``_q0`` …), each ``(projection or "", Asked, link label)``."""

    text: str
    refs: dict[str, tuple[str, Asked, str]]


def derived(of: str) -> Derived | None:
    """The derived answer an ``of:`` text asks for, or None when it refers to no result (or to an
    unknown one: validation names it). A plain result (`parse`) is not a derived answer."""
    if not isinstance(of, str) or parse(of) is not None:
        return None
    refs: dict[str, tuple[str, Asked, str]] = {}
    bad: list[str] = []

    def proj(m: re.Match) -> str:
        asked = parse(m[2])
        if asked is None or not asked.quantity.vector or asked.component:
            bad.append(m[2])
            return m[0]
        key = f"_q{len(refs)}"
        refs[key] = (m[1], asked, m[3].strip().strip("'\""))
        return key

    def ref(m: re.Match) -> str:
        text = m[0]
        asked = parse(text)
        if asked is None:
            if "[" in text or "@" in text:
                bad.append(text)
            return text
        key = f"_q{len(refs)}"
        refs[key] = ("", asked, "")
        return key

    text = _PROJ.sub(proj, of)
    text = _NAME.sub(lambda m: m[0] if _is_call(text, m) else ref(m), text)
    if bad:
        raise ValueError(f"expected results of the of: grammar inside the expression, got {', '.join(bad)}")
    return Derived(text, refs) if refs else None


def _is_call(text: str, m: re.Match) -> bool:
    return text[m.end(): m.end() + 1] == "("
