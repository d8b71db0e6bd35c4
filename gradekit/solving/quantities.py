"""The answer quantities a problem can ask for (the ``of:`` grammar), one row each.

A row states the quantity's name, what goes in its brackets, its SI unit (of the value, or of each
component of a vector), whether it is a vector (``.x``, ``.y``, ``.mag``, ``.angle``), its answer
kind (which measured tolerance default applies) and how people read it. Validation
(`gradekit.bank.schema`), the producer (`gradekit.solving.answers.flat_results`), the tolerance defaults
(`gradekit.solving.tolerances.answer_kind`), carried-forward credit (`gradekit.solving.carry`: a row's stage) and the
documentation read this table.

Any quantity may carry ``@group`` (one superposition part: a load's name, ``gravity`` or
``inertia[k]``) before its component.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


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


QUANTITIES: tuple[Quantity, ...] = (
    Quantity("driver", "", "N*m", False, "", "the driving torque (or force, for a slider driver)", "forces"),
    Quantity("transmission", "", "deg", False, "angle", "the smallest acute transmission angle", "kinematics"),
    Quantity("F", "i,j", "N", True, "force", "the force of link i on link j at their joint", "forces"),
    Quantity("M", "i,j", "N*m", False, "torque", "the couple of link i on link j at a sliding joint", "forces"),
    Quantity("aG", "k", "m/s**2", True, "kinematic", "the acceleration of link k's centre of mass", "kinematics"),
    Quantity("vG", "k", "m/s", True, "kinematic", "the velocity of link k's centre of mass", "kinematics"),
    Quantity("Fi", "k", "N", True, "force", "the inertia force −m·a_G of link k", "inertia"),
    Quantity("a", "P", "m/s**2", True, "kinematic", "the acceleration of point P", "kinematics"),
    Quantity("v", "P", "m/s", True, "kinematic", "the velocity of point P", "kinematics"),
    Quantity("alpha", "k", "rad/s**2", False, "kinematic", "the angular acceleration of link k (CCW +)", "kinematics"),
    Quantity("omega", "k", "rad/s", False, "kinematic", "the angular velocity of link k (CCW +)", "kinematics"),
    Quantity("theta", "k", "deg", False, "angle", "the angle of link k, CCW from +x", "kinematics"),
    Quantity("Ci", "k", "N*m", False, "torque", "the inertia couple −I·α of link k", "inertia"),
    Quantity("h", "k", "m", False, "length", "the offset I·α/(m·a_G) of link k's equivalent inertia force", "inertia"),
    Quantity("param", "name", "", False, "", "a parameter's own value (in its unit)", "given"),
    Quantity("r", "P", "m", True, "length", "the position of point P from the problem's origin", "kinematics"),
    Quantity(
        "shaking", "", "N", True, "force",
        "the shaking force: the sum of the forces the mechanism exerts on the frame (ground pins, slides, the "
        "driver's reaction)", "forces",
    ),
    Quantity(
        "shaking_moment", "", "N*m", False, "torque",
        "the shaking moment about the origin of those forces, with the guides' couples and the driving "
        "torque's reaction (CCW +)", "forces",
    ),
)
BY_NAME = {q.name: q for q in QUANTITIES}
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
