"""The problem definition: frozen records of a validated problem file (what `gradekit.bank.schema`
makes), its vocabularies (dimensions, unit systems, load types, methods), and the order in which
its parameters are computed."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import ClassVar

from gradekit.bank import expr
from gradekit.mechanics.mechanisms import ANGLE_PARAMS as MECHANISM_ANGLES
from gradekit.mechanics.mechanisms import KINDS
from gradekit.solving.keys import Tolerance
from gradekit.solving.tolerances import OFF_FAR

Value = float | str  # a literal number (in the problem's default unit) or a parameter/expression

DIMENSIONS = {
    "length": "mm",
    "force": "N",
    "mass": "kg",
    "inertia": "kg*mm**2",
    "torque": "N*mm",
    "angle": "deg",
    "angular_velocity": "rad/s",
    "angular_acceleration": "rad/s**2",
    "acceleration": "m/s**2",
    "stiffness": "N/mm",
    "damping": "N*s/mm",
    "rotary_damping": "N*mm*s",
}
# ``units: <preset>`` (or ``units: {system: <preset>, …overrides}``): one consistent system each.
# The implicit default (`DIMENSIONS`) keeps acceleration in m/s² for the bank's existing files.
UNIT_SYSTEMS = {
    "SI": {
        "length": "m", "force": "N", "mass": "kg", "inertia": "kg*m**2", "torque": "N*m", "angle": "deg",
        "angular_velocity": "rad/s", "angular_acceleration": "rad/s**2", "acceleration": "m/s**2",
        "stiffness": "N/m", "damping": "N*s/m", "rotary_damping": "N*m*s",
    },
    "mm-N-s": {
        "length": "mm", "force": "N", "mass": "kg", "inertia": "kg*mm**2", "torque": "N*mm", "angle": "deg",
        "angular_velocity": "rad/s", "angular_acceleration": "rad/s**2", "acceleration": "mm/s**2",
        "stiffness": "N/mm", "damping": "N*s/mm", "rotary_damping": "N*mm*s",
    },
    "in-lbf-s": {
        "length": "in", "force": "lbf", "mass": "lbf*s**2/in", "inertia": "lbf*in*s**2", "torque": "lbf*in",
        "angle": "deg", "angular_velocity": "rad/s", "angular_acceleration": "rad/s**2",
        "acceleration": "in/s**2", "stiffness": "lbf/in", "damping": "lbf*s/in", "rotary_damping": "lbf*in*s",
    },
    "ft-lbf-s": {
        "length": "ft", "force": "lbf", "mass": "slug", "inertia": "slug*ft**2", "torque": "lbf*ft",
        "angle": "deg", "angular_velocity": "rad/s", "angular_acceleration": "rad/s**2",
        "acceleration": "ft/s**2", "stiffness": "lbf/ft", "damping": "lbf*s/ft", "rotary_damping": "lbf*ft*s",
    },
}
LOAD_TYPES = ("force", "damper", "spring", "rotary_damper", "resistance")
LOAD_KEYS = {
    "force": ("at", "along", "across", "magnitude", "angle", "relative_angle", "fx", "fy", "torque"),
    "damper": ("between", "bodies", "c"),
    "spring": ("between", "bodies", "k", "free_length"),
    "rotary_damper": ("link", "relative_to", "c"),
    "resistance": ("at", "magnitude"),
}
GRADABLE = 1.05 / OFF_FAR[0]  # the default of constraints.gradable: bands at most 1/10.5 of the answer
ANGLE_PARAMS = MECHANISM_ANGLES  # the registry's angle parameters (gradekit.mechanics.mechanisms)
SHOW = {"dimensions", "loads", "com", "accelerations", "velocities", "angles", "torque", "labels"}
METHODS = ("analytical", "graphical")
ANALYSES = ("static", "dynamic")
_ID = re.compile(r"^[a-z0-9][a-z0-9_-]*$")

@dataclass(frozen=True)
class Parameter:
    """A named value: fixed (``value``) or drawn per student (``range``/``choices``) or derived (``expr``)."""

    name: str
    unit: str
    value: float | None = None
    low: float | None = None
    high: float | None = None
    step: float | None = None
    sigfigs: int | None = None
    choices: tuple[float, ...] = ()
    expr: str | None = None
    symbol: str = ""
    description: str = ""
    decimals: int | None = None

    @property
    def random(self) -> bool:
        return self.low is not None or bool(self.choices)


@dataclass(frozen=True)
class LoadSpec:
    name: str
    body: str
    at: str = ""
    along: Value = 0.0
    across: Value = 0.0
    magnitude: Value | None = None
    angle: Value | None = None
    relative_angle: bool = False
    fx: Value | None = None
    fy: Value | None = None
    torque: Value | None = None
    type: str = "force"  # force | damper | spring | rotary_damper | resistance
    between: tuple[str, ...] = ()  # damper, spring: the two points (solver names)
    bodies: tuple[str, ...] = ()  # the body each end of ``between`` acts on (resistance: ``body``)
    coefficient: Value | None = None  # damper, rotary_damper: c; spring: k
    free_length: Value = 0.0
    relative_to: str = "ground"  # rotary_damper: the body the damping couple reacts on


@dataclass(frozen=True)
class PointSpec:
    """A point the author defines on a body: from point ``at`` (a solver name), ``along`` the body
    axis and ``across`` it (to the left)."""

    name: str  # as printed
    body: str
    at: str
    along: Value = 0.0
    across: Value = 0.0


DEFINED = "+"  # solver names of author-defined points: "+" and the printed name


@dataclass(frozen=True)
class MassSpec:
    body: str
    mass: Value | None = None
    weight: Value | None = None
    inertia: Value = 0.0
    at: str = ""
    along: Value = 0.0
    across: Value = 0.0


@dataclass(frozen=True)
class AnswerSpec:
    key: str
    of: str
    unit: str
    description: str
    sign: str = ""
    points: float = 1.0
    tolerance: Tolerance = Tolerance()
    case: str | None = None
    tolerance_explicit: bool = False  # given in the file (else: the measured or per-kind default)
    # checked by hand, not graded automatically: no band both admits honest work and rejects an answer
    # 10 % off (benchmarks/RESULTS.md says why for each such answer)
    hand_check: bool = False


@dataclass(frozen=True)
class Published:
    """A value printed in the source, with the precision it was printed to."""

    key: str
    value: float
    unit: str
    rel: float
    note: str = ""
    abs: float = 0.0  # in the published unit: for a published zero, or a value printed to fixed decimals

    def accepts(self, got: float) -> bool:
        """*got* (in the published unit) reproduces the printed value within its precision."""
        return abs(got - self.value) <= max(self.rel * abs(self.value), self.abs) * (1 + 1e-12)


@dataclass(frozen=True)
class Constraints:
    transmission_min: float = 0.0
    condition_max: float = 1e4
    grashof: str | None = None
    dead_centre_min: float = 0.0
    answer_min_fraction: float = 0.0
    require: tuple[tuple[str, str], ...] = ()
    # every non-angle answer at least this many bands from zero: a band under 1/10.5 of the answer never
    # admits an answer 10 % off (issue 25); an answer is gradable in a variant only where its honest band is that narrow
    gradable: float = GRADABLE
    distinguish: tuple[tuple[str, tuple[str, ...]], ...] = ()  # (mistake, answer keys)
    distinguish_factor: float = 2.0
    bands: dict[str, Tolerance] = field(default_factory=dict)  # answer key -> band draws are judged by
    FIXED_BAND: ClassVar[dict[bool, Tolerance]] = {  # an answer with no stated band (True: angles)
        False: Tolerance("relative", 0.02, floor=0.01),
        True: Tolerance("relative", 0.0, 1.0, period=360.0),
    }

    def band(self, a):
        """Each variant's half-width of the band the sampler judges answer *a* (an `AnswerBatch`)
        by: ``constraints.bands`` of the file, else the answer's explicit ``tolerance:``, else
        `FIXED_BAND`; never a measured default, so re-deriving tolerances changes no student's values."""
        tol = self.bands.get(a.spec.key)
        if tol is None:
            tol = a.spec.tolerance if a.spec.tolerance_explicit else self.FIXED_BAND[a.unit == "deg"]
        return tol.bands(a.value, a.scale)


@dataclass(frozen=True)
class Figure:
    show: tuple[str, ...] = ("dimensions", "loads", "labels", "angles")
    true_scale: float | None = None  # paper length per mechanism length (e.g. 0.5 = 1:2)
    force_scale: str = ""


@dataclass(frozen=True)
class Problem:
    """One validated bank problem."""

    id: str
    title: str
    source: dict[str, str]
    tags: tuple[str, ...]
    method: str
    analysis: str
    units: dict[str, str]
    kind: str
    branch: int
    driver: str
    labels: dict[str, str]
    point_names: dict[str, str]
    geometry: dict[str, Value]
    inputs: dict[str, Value]
    parameters: dict[str, Parameter]
    loads: tuple[LoadSpec, ...]
    mass: tuple[MassSpec, ...]
    gravity: dict[str, Value] | None
    weight_g: Value | None
    constraints: Constraints
    cases: dict[str, dict[str, Value]]
    statement: str
    answers: tuple[AnswerSpec, ...]
    published: tuple[Published, ...]
    figure: Figure
    notes: str
    path: str = ""
    lines: dict[str, int] = field(default_factory=dict, compare=False)
    origin: str = ""  # the point positions r[P] are measured from (solver name; "" = the driving link's pivot)
    defined_points: dict[str, PointSpec] = field(default_factory=dict)  # solver name ("+P") -> definition
    angle_range: tuple[float, float] = (0.0, 360.0)
    field_lines: dict[str, int] = field(default_factory=dict, compare=False)  # "loads[0].c" -> line
    sigfigs: int = 3  # the significant figures the statement asks every written value to (the honest model's)

    def label(self, body: str) -> str:
        return self.labels.get(body, body)

    def point(self, name: str) -> str:
        if name.startswith(DEFINED):
            return name[len(DEFINED) :]
        return self.point_names.get(name, name)

    def body_of(self, label: str) -> str | None:
        """The body a label (or a body name) names, or None."""
        if label in self.labels.values():
            return next(b for b, lab in self.labels.items() if lab == label)
        return label if label == "ground" or label in KINDS[self.kind].bodies else None

    def line(self, fieldname: str) -> int | None:
        """The line of a field (``loads[0].c``, ``mechanism.geometry.crank``), else of its nearest parent."""
        f = fieldname
        while f:
            if f in self.field_lines:
                return self.field_lines[f]
            f = f.rsplit(".", 1)[0] if "." in f else (f.rsplit("[", 1)[0] if "[" in f else "")
        return None


def order(params: dict[str, Parameter]) -> list[str]:
    """Parameter names with every derived one after what it depends on; ValueError on a cycle."""
    done: list[str] = []
    seen: set[str] = set()

    def visit(n: str, stack: tuple[str, ...]) -> None:
        if n in seen:
            return
        if n in stack:
            raise ValueError(f"expected derived parameters without cycles, got {' -> '.join(stack + (n,))}")
        p = params.get(n)
        if p and p.expr:
            for dep in sorted(expr.names(p.expr) & set(params)):
                visit(dep, stack + (n,))
        seen.add(n)
        done.append(n)

    for n in params:
        visit(n, ())
    return done
