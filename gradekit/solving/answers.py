"""Answers phase: solved batches → named results → each answer's value, unit and tolerance scale.

`flat_results` names every quantity a mechanism reports (``F[1,2].mag``, ``aG[2].angle``,
``driver``…; see ``of:`` in problem_bank/README.md) by running the producers the rows of the quantity
table (`gradekit.solving.quantities`) declare, lazily, so only what a problem asks for is computed.
`Result` is one variant as `gradekit solve` reports it; `ResultBatch` many.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.model import DEFINED, Problem
from gradekit.errors import ConditioningError, GeometryError
from gradekit.mechanics.forces import Solution, Solutions, frame_reaction, spot_point
from gradekit.mechanics.model import Batched, Refusals
from gradekit.solving import quantities


@dataclass
class CaseResult:
    """The solution of one case (position) of a problem, with its flat named results in SI.

    ``solution`` (the linkage, forces and free-body data of this one variant) is made on first
    use from *make* when given: keys and grading read ``results`` only.
    """

    name: str | None
    values: dict[str, float]
    solution_: Solution | None = None
    results: Mapping = field(default_factory=dict)
    make: object = field(default=None, repr=False, compare=False)

    @property
    def solution(self) -> Solution:
        if self.solution_ is None:
            self.solution_ = self.make()
        return self.solution_


class Answers(list):
    """The answers of a variant in the problem's order; ``answers["T"]`` also finds one by key."""

    def __getitem__(self, k):
        if isinstance(k, str):
            for a in self:
                if a.key == k:
                    return a
            raise KeyError(k)
        return super().__getitem__(k)


@dataclass
class SolvedAnswer:
    """One answer of one solved variant: its value in the answer's unit, how it is asked and graded (the
    grader's submitted answer is `gradekit.grading.reader.Answer`)."""

    key: str
    value: float
    unit: str
    description: str
    sign: str
    points: float
    tolerance: object
    of: str
    case: str | None
    scale: float = 0.0  # the variant's largest answer of the same dimension (for tolerance floors)
    base_key: str = ""  # the problem's answer key (``key`` carries a case suffix for multi-case answers)


@dataclass
class Result:
    """Everything `gradekit solve` reports for one variant."""

    problem: Problem
    values: dict[str, float]
    cases: list[CaseResult]
    answers: Answers
    batch: ResultBatch | None = field(default=None, repr=False, compare=False)  # solved in (row ``index``)
    index: int = field(default=0, repr=False, compare=False)
    # what a later phase makes once from this variant (its carry plan), under that phase's name
    derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def virtual_work_residual(self) -> float:
        return max(c.solution.virtual_work_residual for c in self.cases)

    @property
    def condition_number(self) -> float:
        return max(c.solution.condition_number for c in self.cases)

    @property
    def transmission_angle(self) -> float:
        return min(c.solution.linkage.transmission for c in self.cases)

    @property
    def checks(self) -> dict[str, float]:
        """The cross-checks of the solve: virtual-work residual, condition number, transmission angle."""
        return {
            "virtual_work_residual": self.virtual_work_residual,
            "condition_number": self.condition_number,
            "transmission_angle": self.transmission_angle,
        }


def group_label(problem: Problem, group: str) -> str:
    """A superposition group as ``@group`` names it: a load's name, ``gravity``, ``inertia[k]``."""
    if group.startswith("inertia:"):
        return f"inertia[{problem.label(group.split(':', 1)[1])}]"
    return group


class Results(Mapping):
    """Named results of a batch, ``name -> (array over variants, SI unit)``, each computed on first use.

    A mechanism reports dozens of quantities (every force in every superposition part, every
    point's velocity…) and a problem asks for a few: those are the only ones computed.
    """

    def __init__(self) -> None:
        self._items: dict[str, object] = {}

    def put(self, name: str, make) -> None:
        """Register *make* (a callable returning (values, unit)) or a computed (values, unit) pair."""
        self._items[name] = make

    def __getitem__(self, name: str) -> tuple[np.ndarray, str]:
        item = self._items[name]
        if callable(item):
            item = self._items[name] = item()
        return item

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self):
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def setdefault(self, name: str, value):
        if name not in self._items:
            self._items[name] = value
        return self[name]

    def row(self, i: int) -> RowResults:
        return RowResults(self, i)


class RowResults(Mapping):
    """One variant's view of `Results`: ``name -> (float, SI unit)``."""

    def __init__(self, parent: Results, i: int) -> None:
        self._parent, self._i = parent, i

    def __getitem__(self, name: str) -> tuple[float, str]:
        values, unit = self._parent[name]
        return float(values[self._i]), unit

    def __contains__(self, name: object) -> bool:
        return name in self._parent

    def __iter__(self):
        return iter(self._parent)

    def __len__(self) -> int:
        return len(self._parent)

    def setdefault(self, name: str, value):
        if name not in self._parent:
            self._parent.put(name, (np.full(self._i + 1, value[0]), value[1]))
        return self[name]


def wrap(degrees, angle_range: tuple[float, float] = (0.0, 360.0)) -> np.ndarray:
    """Angles in degrees reported in the problem's range: [0, 360) or [-180, 180)."""
    lo = angle_range[0]
    return (np.asarray(degrees, float) - lo) % 360.0 + lo


class Solved:
    """One solved batch as the producers of the quantity table (`gradekit.solving.quantities`) read it,
    and the named results they put (`put`, `vector`), each computed on first use."""

    def __init__(self, problem: Problem, sol: Solutions, values: dict | None, out: Results) -> None:
        self.problem, self.sol, self.values, self.results = problem, sol, values, out
        self.link = sol.linkage
        self.label = problem.label
        self.n = sol.n
        self.put = out.put
        self.angle_range = problem.angle_range
        parts = {None: sol.total, **{g: sol.x[:, :, k] for k, g in enumerate(sol.group_names)}}
        # (``@group`` suffix or "" for the total, the unknowns of that superposition part)
        self.groups = [("" if g is None else "@" + group_label(problem, g), x) for g, x in parts.items()]
        # the origin of positions ``r[P]`` and of the shaking moment, as (x, y), found on first use
        self.origin = _once(_origin(problem, sol))

    def arr(self, x) -> np.ndarray:
        """*x* broadcast to one value per variant."""
        return np.broadcast_to(np.asarray(x, float), (self.n,))

    def wrap(self, degrees) -> np.ndarray:
        """Angles in degrees, in the problem's range."""
        return wrap(degrees, self.angle_range)

    def vector(self, name: str, x, y, unit: str) -> None:
        """Put a vector's five names (``name``: its magnitude, ``.x``, ``.y``, ``.mag``, ``.angle``) from
        its components *x*, *y* (arrays, or callables returning them)."""
        out, put, arr, rng = self.results, self.put, self.arr, self.angle_range
        # the components, worked out on the first read of any of the five names
        xy = _once(lambda: (arr(x() if callable(x) else x), arr(y() if callable(y) else y)))

        put(name + ".x", lambda: (xy()[0], unit))
        put(name + ".y", lambda: (xy()[1], unit))
        put(name + ".mag", lambda: (np.hypot(*xy()), unit))
        put(name + ".angle", lambda: (wrap(np.degrees(np.arctan2(xy()[1], xy()[0])), rng), "deg"))
        put(name, lambda: out[name + ".mag"])

    def points(self) -> dict:
        """Every named point: the mechanism's (computed), the problem's own (each computed on first use)."""
        link = self.link
        points = dict(link.points)
        for pname, spot in self.sol.analysis.points.items():
            points[pname] = _once(lambda spot=spot: spot_point(link, spot))
        return points

    def frame_reaction(self, x: np.ndarray):
        """The forces the mechanism exerts on the frame under the unknowns *x* (one superposition part)
        and their moment about the origin, computed on the first call of the returned function."""
        link, arr, origin = self.link, self.arr, self.origin
        return _once(lambda: frame_reaction(link, x, np.stack([arr(origin()[0]), arr(origin()[1])], axis=-1)))


def flat_results(problem: Problem, sol: Solutions, values: dict | None = None) -> Results:
    """Name every reported quantity of every variant (see ``of:`` in problem_bank/README.md); SI.

    Each producer of the quantity table puts its rows' results (lazily); then each derived answer.
    *values* (the case's parameter values, in their units) are needed only by ``param[...]`` and by
    derived answers that use parameters.
    """
    out = Results()
    solved = Solved(problem, sol, values, out)
    for produce in quantities.PRODUCERS:
        produce(solved)
    n = sol.n
    for spec in problem.answers:
        d = quantities.derived(spec.of)
        if d is not None and spec.of not in out:
            out.put(spec.of, lambda d=d, spec=spec: _derived(problem, d, spec.unit, out, sol, values, n))
    return out


def _once(make):
    """*make*() on the first call, kept for the later ones. The producers make about fifty of these a
    solve (a vector's components, a point, the shaking force), and `generate` solves one variant at a
    time in every worker: `functools.cache` costs about 15 µs to make, a closure well under one."""
    kept = []

    def get():
        if not kept:
            kept.append(make())
        return kept[0]

    return get


def _origin(problem: Problem, sol: Solutions):
    """The origin of positions ``r[P]``: the problem's ``origin:`` point, else the driving link's pivot."""
    link = sol.linkage

    def get():
        if problem.origin.startswith(DEFINED):
            p = spot_point(link, sol.analysis.points[problem.origin])
        elif problem.origin:
            p = link.points[problem.origin]
        else:
            p = link.bodies[link.input_body].origin
        return (p.x.v, p.y.v)

    return get


def _derived(problem: Problem, d, unit: str, out: Results, sol: Solutions, values: dict | None, n: int):
    """A derived answer's values, in the SI unit of its answer unit (degrees for angles)."""
    env: dict[str, np.ndarray] = {}
    for name in expr.names(d.text):
        if name in d.refs:
            proj, asked, label = d.refs[name]
            if not proj:
                env[name] = out[quantities.name_of(asked)][0]
                continue
            stem = quantities.name_of(asked)
            fx, fy = out[stem + ".x"][0], out[stem + ".y"][0]
            body = problem.body_of(label)
            th = np.asarray(sol.linkage.bodies[body].angle.v, float)
            env[name] = fx * np.cos(th) + fy * np.sin(th) if proj == "along" else -fx * np.sin(th) + fy * np.cos(th)
        else:
            p = problem.parameters[name]
            v = np.asarray((values or {})[name], float)
            env[name] = v if p.unit in ("deg", "degree") else units.to_si(v, p.unit)
    value = np.broadcast_to(np.asarray(expr.evaluate_many(d.text, env), float), (n,))
    if units.si_unit(unit) == units.si_unit("deg"):
        return wrap(value, problem.angle_range), "deg"
    si = units.si_unit(unit)
    readable = next((q.si for q in quantities.QUANTITIES if q.si and units.si_unit(q.si) == si), si)
    return value, readable


@dataclass
class CaseBatch:
    """One case (position) of a problem solved for every variant of a batch."""

    name: str | None
    values: dict[str, np.ndarray]
    solutions: Solutions
    results: Results


@dataclass
class AnswerBatch:
    """One answer of every variant: values (in the answer's unit) and the variant's scale."""

    key: str
    value: np.ndarray
    unit: str
    spec: object
    case: str | None
    scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def band(self) -> np.ndarray:
        """Half-width of each variant's acceptance band (its tolerance with the floor resolved)."""
        return self.spec.tolerance.bands(self.value, self.scale)


@dataclass
class ResultBatch(Batched):
    """A batch of variants of one problem, solved together.

    ``answers[key]`` is an array of every variant's value in the answer's unit; ``ok`` masks the
    refused variants, ``reason(i)`` says why one was refused. ``take(i)`` is one variant's `Result`.
    """

    problem: Problem
    values: dict[str, np.ndarray]
    cases: list[CaseBatch]
    answer_list: list[AnswerBatch]
    refused: Refusals
    # what a later phase makes once from the whole batch (its catalogued mistakes, its carry plans),
    # under that phase's name
    derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def answers(self) -> dict[str, np.ndarray]:
        return {a.key: a.value for a in self.answer_list}

    @property
    def units(self) -> dict[str, str]:
        return {a.key: a.unit for a in self.answer_list}

    def reason(self, i: int) -> str:
        return self.refused.reason(i)

    @property
    def virtual_work_residual(self) -> np.ndarray:
        return np.maximum.reduce([c.solutions.virtual_work_residual for c in self.cases])

    @property
    def condition_number(self) -> np.ndarray:
        return np.maximum.reduce([c.solutions.condition_number for c in self.cases])

    def condition_above(self, limit: float) -> np.ndarray:
        """Where any case's condition number exceeds *limit* (an SVD only where bounds cannot tell)."""
        return np.logical_or.reduce([c.solutions.conditioning.above(limit) for c in self.cases])

    @property
    def transmission_angle(self) -> np.ndarray:
        return np.minimum.reduce([np.broadcast_to(c.solutions.linkage.transmission, (self.n,)) for c in self.cases])

    def take(self, i: int) -> Result:
        """Variant *i* as a `Result`; raises its `GeometryError` when it was refused."""
        pr = self.problem
        if self.refused.mask[i]:
            ill = any(c.solutions.ill_conditioned[i] for c in self.cases)
            cls = ConditioningError if ill else GeometryError
            raise cls(f"{pr.id}: {self.reason(i)}", path=pr.path, field="mechanism")
        cases = [
            CaseResult(
                c.name,
                {k: float(v[i]) for k, v in c.values.items()},
                None,
                c.results.row(i),
                lambda sols=c.solutions: sols.at(i),
            )
            for c in self.cases
        ]
        answers = Answers(
            SolvedAnswer(
                a.key,
                float(a.value[i]),
                a.unit,
                a.spec.description,
                a.spec.sign,
                a.spec.points,
                a.spec.tolerance.resolve(float(a.scale[i])),
                a.spec.of,
                a.case,
                float(a.scale[i]),
                base_key=a.spec.key,
            )
            for a in self.answer_list
        )
        return Result(pr, {k: float(v[i]) for k, v in self.values.items()}, cases, answers, self, i)


def published_mismatches(result: Result) -> list[str]:
    """Every published value (``published:``) the solved published variant *result* does not reproduce
    within its printed precision (``rel`` of the value, or ``abs`` in its unit), as one line each."""
    got = {a.key: a for a in result.answers}
    out = []
    for pub in result.problem.published:
        a = got.get(pub.key)
        if a is None:
            out.append(f"{pub.key}: published, but no answer has this key")
            continue
        value = a.value if a.unit == pub.unit else units.convert(a.value, a.unit, pub.unit)
        if pub.unit in ("deg", "degree"):
            value = (value - pub.value + 180.0) % 360.0 - 180.0 + pub.value
        if not pub.accepts(value):
            out.append(f"{pub.key}: published {pub.value:g} {pub.unit}, solved {value:.6g} {pub.unit}")
    return out
