"""Error carried forward: which answers follow from which, and each later answer recomputed from a student's own.

A solved variant (`gradekit.solving.answers.Result`) knows more than its answers: which bodies carry
inertia loads, what each load does to every unknown (the assembled system A·x + B = 0 of
`gradekit.mechanics.forces.Solution`), which answers are kinematic quantities of which body. From
that, without anything written per problem:

- `dependencies` gives every answer its stage (``given`` → ``kinematics`` → ``inertia`` →
  ``forces`` → ``total``) and the answers upstream of it that it can be recomputed from, or why it
  cannot be carried;
- `carried` recomputes each later answer from a student's submitted upstream values in place of the
  exact ones: an inertia force −m·a_G from their a_G, a couple −I·α from their α, an offset
  h = |C|/|F| from their inertia answers, the pin forces and the driver from their inertia loads
  (the forces are linear in the loads: one response per body to a unit force in x and in y at its
  centre of mass and to a unit couple, so a recomputation is a product, not a solve), and a
  superposition total from their parts. Gravity and external loads stay exact.

What a student's values determine: a vector asked by its magnitude only keeps the exact direction
(by its direction only, the exact magnitude; by one component, the exact other one). Where a
problem asks the inertia force or couple itself, the forces follow from those answers; where a
student left them blank, from their kinematics. A graphical problem's forces follow the
equivalent offset force, so its couple comes from the offset h (with the sense of their α) before α.

Whether a later answer matches its carried reference is `Carried.accepts` (the answer's
`gradekit.solving.keys.Tolerance`); `credited` lists the answers wrong against the key that match theirs.

Batch first: `plan_many` does the work for every variant of a solved batch at once (one batched
solve for the unit responses, the stems' maps read off `flat_results`, the numeric dependence
tests as arrays) and keeps it on the batch; `plan` of a `Result` is its row of that plan, so a
class's students cost one plan per solved batch plus a few hundred microseconds each.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from gradekit import units
from gradekit.mechanics.forces import Solutions, spot_point
from gradekit.mechanics.model import Refusals
from gradekit.numbers import fmt
from gradekit.solving import quantities
from gradekit.solving.answers import (
    AnswerBatch,
    CaseBatch,
    Result,
    ResultBatch,
    SolvedAnswer,
    flat_results,
    group_label,
    wrap,
)
from gradekit.solving.keys import Tolerance

STAGES = ("given", "kinematics", "inertia", "forces", "total")
_parse = lru_cache(maxsize=1024)(quantities.parse)  # the same few of: texts for every student
_ZERO = 1e-9  # a response (unit-free: per newton, couples per newton times the mechanism's scale) below this is none
_INERTIA = "inertia:"


@dataclass(frozen=True)
class Dependency:
    """Where one answer stands: its stage, what it is recomputed from, or why it is not.

    ``upstream`` are the problem's answer keys a carried value may be computed from, in order of
    preference (the inertia answers before the kinematics used where those are blank; a total's
    parts). ``held`` are the superposition groups (as ``@group`` names them: a load's name,
    ``gravity``, ``inertia[k]``) that change this answer but stay exact: given loads, and the
    inertia of a body none of whose kinematics or inertia answers is asked. ``reason`` says why
    the answer cannot be carried ("" when it can).
    """

    key: str
    stage: str
    upstream: tuple[str, ...] = ()
    held: tuple[str, ...] = ()
    reason: str = ""

    @property
    def carriable(self) -> bool:
        return not self.reason


@dataclass(frozen=True)
class Used:
    """One submitted upstream value a carried reference was computed from, in its answer's unit."""

    key: str
    value: float
    unit: str
    wrong: bool  # outside its own tolerance around the key

    def describe(self) -> str:
        """``alpha2 = 480 rad/s²``."""
        return f"{self.key} = {units.with_unit(fmt(self.value, 3), self.unit)}"


@dataclass(frozen=True)
class Carried:
    """One answer recomputed from the student's own upstream values (``value``, in ``unit``)."""

    key: str
    value: float
    unit: str
    used: tuple[Used, ...]
    tolerance: Tolerance = field(default_factory=Tolerance)

    @property
    def wrong(self) -> tuple[Used, ...]:
        """The upstream values used that were wrong against the key."""
        return tuple(u for u in self.used if u.wrong)

    def accepts(self, answer: float, tolerance: Tolerance | None = None) -> bool:
        """True when *answer* (in ``unit``) is within *tolerance* (the answer's own by default) of
        the carried value: the student worked on correctly from their own upstream values."""
        return (tolerance or self.tolerance).accepts(answer, self.value)

    def describe(self) -> str:
        """``consistent with your alpha2 = 480 rad/s² and aG2 = 210000 mm/s²``: the wrong values used
        (all of them when none was wrong)."""
        shown = [u.describe() for u in (self.wrong or self.used)]
        listed = shown[0] if len(shown) == 1 else ", ".join(shown[:-1]) + " and " + shown[-1]
        return f"consistent with your {listed}"


def dependencies(result: Result) -> dict[str, Dependency]:
    """Every answer of *result* (by key, in the problem's order) with its stage and upstream answers."""
    return plan(result).dependencies


def carried(
    result: Result, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
) -> dict[str, Carried]:
    """The later answers of *result* recomputed from a student's *submitted* values (answer key →
    value in the answer's unit; blank answers absent or NaN), for each answer with at least one
    upstream value present and wrong. *tolerances* (answer key → tolerance, e.g. an instructor's
    override) decide what is wrong; each answer's own by default."""
    return plan(result).carried(submitted, tolerances)


def credited(
    result: Result, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
) -> dict[str, Carried]:
    """The answers the student got wrong against the key but right from their own upstream values:
    what earns carried credit (`carried`, with `Carried.accepts`, *tolerances* judging both)."""
    return plan(result).credited(submitted, tolerances)


def plan(result: Result) -> Plan:
    """The carry plan of one solved variant: its row of `plan_many` of the batch it was solved in
    (made once per batch and kept on it), kept on *result*."""
    made = result.derived.get("carry")
    if made is None:
        if result.batch is None:
            raise ValueError("expected a Result taken from its solved batch (ResultBatch.take), got one without")
        made = result.derived["carry"] = plan_many(result.batch).at(result.index, result.answers)
    return made


def plan_many(batch: ResultBatch) -> BatchPlan:
    """What can be carried in every variant of a solved batch, made once and kept on the batch."""
    made = batch.derived.get("carry")
    if made is None:
        made = batch.derived["carry"] = BatchPlan(batch)
    return made


def _present(value) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _stem(asked: quantities.Asked) -> str:
    return quantities.name_of(quantities.Asked(asked.quantity, asked.args, "", ""))


def _component(vec: np.ndarray, component: str, angle_range) -> float:
    """A vector's component as `flat_results` names it (SI; angles in degrees in the problem's range)."""
    if component == "x":
        return float(vec[0])
    if component == "y":
        return float(vec[1])
    if component == "angle":
        return float(wrap(math.degrees(math.atan2(vec[1], vec[0])), angle_range))
    return float(np.hypot(vec[0], vec[1]))


def _compose(exact: np.ndarray, given: dict[str, float]) -> np.ndarray:
    """A vector from the components a student gave (SI, angles in degrees), the rest exact: by its
    magnitude and direction when they gave either, else by x and y."""
    if "mag" in given or "angle" in given:
        mag = given.get("mag", float(np.hypot(*exact)))
        ang = math.radians(given["angle"]) if "angle" in given else math.atan2(exact[1], exact[0])
        return np.array([mag * math.cos(ang), mag * math.sin(ang)])
    return np.array([given.get("x", exact[0]), given.get("y", exact[1])])


def _rows(x, n: int, *tail: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, float), (n, *tail))


_DOFS = ("x", "y", "mag", "angle", "couple")  # what an answer can move of a body's inertia load


@dataclass
class _Body:
    """An inertial body of a batch: its exact inertia load, its unit responses, the answers giving its load."""

    mass: np.ndarray  # (N,)
    inertia: np.ndarray  # (N,)
    force: np.ndarray  # (N, 2): the exact inertia force −m·a_G (N)
    couple: np.ndarray  # (N,): the exact inertia couple −I·α (N·m)
    units: np.ndarray  # (N, ncol, 3): the unknowns due to a unit force in x, in y at G and a unit couple
    forces: list[tuple[str, dict[str, str]]] = field(default_factory=list)  # (Fi | aG, component -> key)
    couples: list[tuple[str, str]] = field(default_factory=list)  # (Ci | alpha | h, key), by preference

    def keys(self, kinds=("Fi", "aG", "Ci", "alpha", "h")) -> list[str]:
        out = [k for kind, keys in self.forces if kind in kinds for k in keys.values()]
        return out + [k for kind, k in self.couples if kind in kinds]


class _Case:
    """One case (position) of a batch: each group's unknowns, each inertial body's unit responses,
    each force stem's linear map, and what those say about dependence, for every variant at once."""

    def __init__(self, problem, case: CaseBatch, answers: list[AnswerBatch]) -> None:
        sols: Solutions = case.solutions
        if sols.matrix is None or sols.rhs is None:
            raise ValueError("expected solutions with their assembled systems (matrix and rhs), got none")
        self.problem, self.case, self.sols = problem, case, sols
        link = sols.linkage
        n = self.n = sols.n
        self.scale = _rows(link.scale, n)
        self.groups = list(sols.group_names)
        self.labels = {group_label(problem, g): g for g in self.groups}
        inertial = [g[len(_INERTIA):] for g in self.groups if g.startswith(_INERTIA)]
        bad = sols.refused.mask
        A, B = sols.matrix, sols.rhs
        nrow, ncol = A.shape[1], A.shape[2]
        row = {b: 3 * i for i, b in enumerate(link.bodies)}
        E = np.zeros((n, nrow, 3 * len(inertial)))
        for k, body in enumerate(inertial):
            o = link.bodies[body].origin
            d = _rows(sols.states[body].g, n, 2) - np.stack([_rows(o.x.v, n), _rows(o.y.v, n)], axis=-1)
            r, c = row[body], 3 * k
            E[:, r, c] = E[:, r + 1, c + 1] = E[:, r + 2, c + 2] = 1.0
            E[:, r + 2, c], E[:, r + 2, c + 1] = -d[:, 1], d[:, 0]
        with np.errstate(all="ignore"):  # refused variants (never asked for) solve an identity
            A = np.where(bad[:, None, None], np.eye(nrow, ncol), A)
            Y = -np.linalg.solve(A, np.nan_to_num(np.concatenate([B, E], axis=2) * ~bad[:, None, None]))
        G = len(self.groups)
        self.parts = Y[:, :, :G]  # (N, ncol, G): each group's unknowns
        self.bodies: dict[str, _Body] = {}
        for k, body in enumerate(inertial):
            st = sols.states[body]
            self.bodies[body] = _Body(
                _rows(st.mass, n), _rows(st.inertia, n), _rows(st.inertia_force, n, 2), _rows(st.inertia_couple, n),
                Y[:, :, G + 3 * k : G + 3 * k + 3],
            )
        self._sources(answers)
        self.maps = self._maps(answers, ncol)
        self._judge()

    def _sources(self, answers: list[AnswerBatch]) -> None:
        """Attach to each inertial body the answers that give its inertia force and couple."""
        problem = self.problem
        forces: dict[str, dict[str, dict[str, str]]] = {}
        couples: dict[str, dict[str, str]] = {}
        for a in answers:
            asked = _parse(a.spec.of)
            if asked is None or asked.group:
                continue
            name = asked.quantity.name
            body = problem.body_of(asked.args) if name in ("aG", "Fi", "Ci", "alpha", "h") else None
            if name == "a":
                name, body = "aG", self._body_at(asked.args)
            if body not in self.bodies:
                continue
            if name in ("aG", "Fi"):
                forces.setdefault(body, {}).setdefault(name, {}).setdefault(asked.component or "mag", a.key)
            elif name in ("Ci", "alpha", "h"):
                couples.setdefault(body, {}).setdefault(name, a.key)
        order = ("Ci", "h", "alpha") if problem.method == "graphical" else ("Ci", "alpha", "h")
        for body, b in self.bodies.items():
            b.forces = [(kind, forces[body][kind]) for kind in ("Fi", "aG") if kind in forces.get(body, {})]
            b.couples = [(kind, couples[body][kind]) for kind in order if kind in couples.get(body, {})]

    def _body_at(self, printed: str) -> str | None:
        """The inertial body whose centre of mass is point *printed* (same place and acceleration in
        every variant solved), or None."""
        sols, n = self.sols, self.n
        link = sols.linkage
        spots = {**link.points, **sols.analysis.points}
        name = next((s for s in spots if self.problem.point(s) == printed), None)
        if name is None:
            return None
        p = spots[name] if name in link.points else spot_point(link, spots[name])
        pos = np.stack([_rows(p.x.v, n), _rows(p.y.v, n)], axis=-1)
        acc = np.stack([_rows(p.x.dd, n), _rows(p.y.dd, n)], axis=-1)
        ok = sols.ok
        for body in self.bodies:
            st = sols.states[body]
            g, a_g = _rows(st.g, n, 2), _rows(st.a_g, n, 2)
            size = np.maximum(np.hypot(*acc.T), np.hypot(*a_g.T))
            same = (np.hypot(*(pos - g).T) <= 1e-9 * self.scale) & (np.hypot(*(acc - a_g).T) <= 1e-9 * size)
            if ok.any() and same[ok].all():
                return body
        return None

    def _maps(self, answers: list[AnswerBatch], ncol: int) -> dict[str, tuple[np.ndarray, str]]:
        """Each force stem's (N, components, unknowns) linear map and SI unit, read off the named
        results of unit unknowns (so the answers' own definitions, `flat_results`, decide)."""
        stems = {}
        for a in answers:
            asked = _parse(a.spec.of)
            if asked is not None and asked.quantity.stage == "forces":
                stems[_stem(asked)] = asked.quantity.vector
        if not stems:
            return {}
        sols, n = self.sols, self.n

        def named(total: np.ndarray):
            m = len(total)
            unit = Solutions(sols.linkage, sols.analysis, (), np.zeros((m, ncol, 0)), total, sols.states,
                             np.zeros(m), np.zeros(m), None, Refusals(m), np.zeros(m, bool))
            return flat_results(self.problem, unit, self.case.values)

        def read(results, stem, vector):
            names = (stem + ".x", stem + ".y") if vector else (stem,)
            return np.stack([results[s][0] for s in names]), results[names[0]][1]

        out = {}
        if n == 1:  # one variant: every unit unknown is a row of one batch
            results = named(np.eye(ncol))
            for stem, vector in stems.items():
                m, si = read(results, stem, vector)
                out[stem] = (m[None], si)
            return out
        maps = {stem: np.zeros((n, 2 if vector else 1, ncol)) for stem, vector in stems.items()}
        si = {}
        for j in range(ncol):
            total = np.zeros((n, ncol))
            total[:, j] = 1.0
            results = named(total)
            for stem, vector in stems.items():
                col, si[stem] = read(results, stem, vector)
                maps[stem][:, :, j] = col.T
        return {stem: (maps[stem], si[stem]) for stem in stems}

    def _judge(self) -> None:
        """For every variant: which groups change each stem, and which of each body's load
        directions (``_DOFS``) do; a response is unit-free (per newton, a couple per newton times
        the mechanism's scale, a moment answer divided by it) and none below ``_ZERO``. All stems
        at once: their maps stacked, each stem's rows reduced together."""
        stems = list(self.maps)
        self.each: dict[str, np.ndarray] = {}  # stem -> (N, G) bool
        self.moves: dict[tuple[str, str], np.ndarray] = {}  # (stem, body) -> (N, len(_DOFS)) bool
        flags = [(b.mass != 0)[:, None] for b in self.bodies.values()]
        flags += [(b.inertia != 0)[:, None] for b in self.bodies.values()]
        if stems:
            M = np.concatenate([self.maps[s][0] for s in stems], axis=1)  # (N, D, ncol)
            starts = np.cumsum([0] + [self.maps[s][0].shape[1] for s in stems[:-1]])
            each = np.maximum.reduceat(np.abs(np.einsum("ndc,ncg->ndg", M, self.parts)), starts, axis=1)
            total = np.maximum.reduceat(np.abs(np.einsum("ndc,nc->nd", M, self.parts.sum(axis=2))), starts, axis=1)
            size = np.maximum(np.maximum(total, each.max(axis=2, initial=0.0)), 1e-300)
            each = each > _ZERO * size[:, :, None]  # (N, S, G)
            rows = np.concatenate([np.full(self.maps[s][0].shape[1], _is_moment(self.maps[s][1])) for s in stems])
            per = np.where(rows[None, :], 1.0 / self.scale[:, None], 1.0)  # (N, D): a moment per unit length
            for k, stem in enumerate(stems):
                self.each[stem] = each[:, k]
            flags.append(each.reshape(self.n, -1))
            for body, b in self.bodies.items():
                r = np.einsum("ndc,nck->ndk", M, b.units) * per[:, :, None]
                r[:, :, 2] *= self.scale[:, None]
                size = np.hypot(*b.force.T)
                u = np.where(size[:, None] > 0, b.force / np.where(size > 0, size, 1.0)[:, None], [1.0, 0.0])
                along = r[:, :, 0] * u[:, None, 0] + r[:, :, 1] * u[:, None, 1]
                across = -r[:, :, 0] * u[:, None, 1] + r[:, :, 1] * u[:, None, 0]
                dofs = np.abs(np.stack([r[:, :, 0], r[:, :, 1], along, across, r[:, :, 2]], axis=-1))
                moves = np.maximum.reduceat(dofs, starts, axis=1) > _ZERO  # (N, S, len(_DOFS))
                for k, stem in enumerate(stems):
                    self.moves[(stem, body)] = moves[:, k]
                flags.append(moves.reshape(self.n, -1))
        # variants alike in all of these have the same dependencies
        self.signature = np.concatenate(flags, axis=1) if flags else np.zeros((self.n, 0), bool)


def _is_moment(si: str) -> bool:
    return units.si_unit(si) == units.si_unit("N*m")


class BatchPlan:
    """What can be carried in every variant of a solved batch (`plan_many`); `at` is one variant's."""

    def __init__(self, batch: ResultBatch) -> None:
        self.batch = batch
        self.problem = batch.problem
        self.cases = [_Case(self.problem, c, [a for a in batch.answer_list if a.case == c.name]) for c in batch.cases]
        self.case_of = {a.key: next(c for c in self.cases if c.case.name == a.case) for a in batch.answer_list}
        self.si = {a.key: self.case_of[a.key].case.results[a.spec.of][1] for a in batch.answer_list}
        self.of = {a.key: a.spec.of for a in batch.answer_list}
        self.parts: dict[tuple[int, str], dict[str, dict[str, str]]] = {}
        for a in batch.answer_list:
            asked = _parse(a.spec.of)
            if asked is not None and asked.group:
                case = id(self.case_of[a.key])
                self.parts.setdefault((case, _stem(asked)), {}).setdefault(asked.group, {}).setdefault(
                    asked.component or "mag", a.key)
        self._memo: dict[bytes, dict[str, Dependency]] = {}

    def at(self, i: int, answers: list[SolvedAnswer] | None = None) -> Plan:
        """Variant *i* (its answers from ``batch.take(i)`` unless given)."""
        return Plan(self, i, list(answers if answers is not None else self.batch.take(i).answers))

    def dependencies(self, i: int) -> dict[str, Dependency]:
        """Variant *i*'s dependencies (shared by every variant alike in what changes what)."""
        sig = b"".join(np.packbits(c.signature[i]).tobytes() for c in self.cases)
        if sig not in self._memo:
            self._memo[sig] = {a.key: self._dependency(a, i) for a in self.batch.answer_list}
        return self._memo[sig]

    def _dependency(self, a: AnswerBatch, i: int) -> Dependency:
        asked = _parse(a.spec.of)
        if asked is None:
            d = quantities.derived(a.spec.of)
            if d is None:
                return Dependency(a.key, "given", reason="a given value: nothing upstream")
            stage = max((q.quantity.stage for _p, q, _l in d.refs.values()), key=STAGES.index)
            return Dependency(a.key, stage, reason="an expression of other results: not carried")
        stage = asked.quantity.stage
        if stage == "given":
            return Dependency(a.key, stage, reason="a given value: nothing upstream")
        if stage == "kinematics":
            return Dependency(a.key, stage, reason="kinematics: the first stage, computed from the given values only")
        case = self.case_of[a.key]
        if stage == "inertia":
            b = case.bodies.get(self.problem.body_of(asked.args))
            want = {"Fi": ("aG",), "Ci": ("alpha",), "h": ("Fi", "aG", "Ci", "alpha")}[asked.quantity.name]
            upstream = tuple(b.keys(want)) if b is not None else ()
            if upstream:
                return Dependency(a.key, stage, upstream)
            needs = {"Fi": "a_G", "Ci": "α", "h": "its inertia force and couple (or a_G and α)"}[asked.quantity.name]
            return Dependency(a.key, stage, reason=f"its upstream ({needs} of link {asked.args}) is not asked")
        stem = _stem(asked)
        if asked.group:
            group = case.labels.get(asked.group, asked.group)
            if not group.startswith(_INERTIA):
                why = f"a part due to {asked.group}, a given load: nothing upstream"
                return Dependency(a.key, "forces", reason=why)
            body = group[len(_INERTIA):]
            keys = self._body_keys(case, stem, body, i)
            if keys:
                return Dependency(a.key, "forces", tuple(keys))
            why = f"its upstream (the kinematics or inertia of link {self.problem.label(body)}) is not asked"
            return Dependency(a.key, "forces", reason=why)
        parts = self.parts.get((id(case), stem), {})
        upstream: list[str] = [k for comps in parts.values() for k in comps.values()]
        held = []
        for g, group in enumerate(case.groups):
            label = group_label(self.problem, group)
            if label in parts or not case.each[stem][i, g]:
                continue
            keys = self._body_keys(case, stem, group[len(_INERTIA):], i) if group.startswith(_INERTIA) else []
            upstream += [k for k in keys if k not in upstream]
            if not keys:
                held.append(label)
        stage = "total" if parts else "forces"
        reason = ""
        if not upstream:
            if not held:
                reason = "no load acts on it"
            elif self.problem.analysis == "dynamic" and any(h.startswith("inertia[") for h in held):
                reason = "its inertia upstream (the kinematics or inertia answers of the links) is not asked"
            else:
                reason = f"it follows from given loads only ({', '.join(held)})"
        return Dependency(a.key, stage, tuple(upstream), tuple(held), reason)

    def _body_keys(self, case: _Case, stem: str, body: str, i: int) -> list[str]:
        """The answers giving *body*'s inertia load that *stem* responds to (by what each one moves;
        an offset h makes the couple h·|F|, so then the force's answers move the couple too)."""
        b = case.bodies[body]
        moves = dict(zip(_DOFS, case.moves[(stem, body)][i], strict=True))
        by_h = moves["couple"] and any(kind == "h" for kind, _ in b.couples)
        out = [k for _kind, keys in b.forces for c, k in keys.items() if b.mass[i] and (moves[c] or by_h)]
        return out + [k for kind, k in b.couples if moves["couple"] and (b.inertia[i] if kind == "alpha" else
                                                                        b.mass[i] if kind == "h" else True)]


class Plan:
    """What can be carried in one solved variant, and the recomputation from a student's values."""

    def __init__(self, batch: BatchPlan, index: int, answers: list[SolvedAnswer]) -> None:
        self.batch, self.index, self.answers = batch, index, answers
        self.problem = batch.problem
        self.dependencies = batch.dependencies(index)

    def carried(
        self, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
    ) -> dict[str, Carried]:
        """See `carried`: the recomputed answers with at least one wrong upstream value."""
        return {k: c for k, c in self.recompute(submitted, tolerances).items() if c.wrong}

    def credited(
        self, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
    ) -> dict[str, Carried]:
        """See `credited`."""
        tolerances = tolerances or {}
        exact = {a.key: a for a in self.answers}
        out = {}
        for key, c in self.carried(submitted, tolerances).items():
            value = _present(submitted.get(key))
            tol = tolerances.get(key) or exact[key].tolerance
            if value is not None and not tol.accepts(value, exact[key].value) and c.accepts(value, tol):
                out[key] = c
        return out

    def recompute(
        self, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
    ) -> dict[str, Carried]:
        """Every carriable answer recomputed from the student's upstream values present in
        *submitted* (wrong or not), each with the values it used."""
        tolerances = tolerances or {}
        bp = self.batch
        exact = {a.key: a for a in self.answers}
        given: dict[str, float] = {}  # SI (degrees for angles)
        used_of: dict[str, Used] = {}
        for key in {k for d in self.dependencies.values() for k in d.upstream}:
            value = _present(submitted.get(key))
            if value is None:
                continue
            a = exact[key]
            given[key] = units.convert(value, a.unit, bp.si[key])
            used_of[key] = Used(key, value, a.unit, not (tolerances.get(key) or a.tolerance).accepts(value, a.value))
        if not given:
            return {}
        loads = {id(c): self._loads(c, given) for c in bp.cases}
        out = {}
        for a in self.answers:
            dep = self.dependencies[a.key]
            if not dep.carriable:
                continue
            case = bp.case_of[a.key]
            got = self._value(a, dep, case, given, loads[id(case)])
            keys = [k for k in dep.upstream if got is not None and k in got[1]]
            if keys:
                value = units.convert(got[0], bp.si[a.key], a.unit)
                out[a.key] = Carried(a.key, float(value), a.unit, tuple(used_of[k] for k in keys),
                                     tolerances.get(a.key) or a.tolerance)
        return out

    def _force(self, b: _Body, given: dict[str, float], kinds: tuple[str, ...]) -> tuple[np.ndarray, set[str]]:
        """*b*'s inertia force from the student's answers of *kinds* (the first source they gave sets
        whether it is read by magnitude and direction or by components), the rest exact."""
        i = self.index
        present = [(kind, c) for kind, keys in b.forces if kind in kinds
                   for c in [{comp: k for comp, k in keys.items() if k in given}] if c]
        if not present:
            return b.force[i], set()
        polar = bool({"mag", "angle"} & set(present[0][1]))
        got: dict[str, float] = {}
        used = set()
        for kind, comps in present:
            for c, k in comps.items():
                if c in got or (c in ("mag", "angle")) != polar:
                    continue
                v = given[k]
                if kind == "aG":  # −m·a_G
                    v = v + 180.0 if c == "angle" else (b.mass[i] * v if c == "mag" else -b.mass[i] * v)
                got[c] = v
                used.add(k)
        return _compose(b.force[i], got), used

    def _couple(self, b: _Body, given: dict[str, float], kinds: tuple[str, ...], force: np.ndarray):
        """*b*'s inertia couple from the first of the student's answers of *kinds* given (an offset h
        with the sense of their α, else of the exact couple), exact when none is."""
        i = self.index
        alpha = next((k for kind, k in b.couples if kind == "alpha" and k in given and kind in kinds), None)
        for kind, key in b.couples:
            if kind not in kinds or key not in given:
                continue
            if kind == "Ci":
                return given[key], {key}
            if kind == "alpha":
                return -b.inertia[i] * given[key], {key}
            if b.mass[i]:  # h: |C| = h·|F|, on the side the couple turns
                sense = -b.inertia[i] * given[alpha] if alpha is not None else b.couple[i]
                size = given[key] * float(np.hypot(*force))
                return math.copysign(size, sense or 1.0), {key} | ({alpha} if alpha is not None else set())
        return b.couple[i], set()

    def _loads(self, case: _Case, given: dict[str, float]) -> dict[str, tuple[np.ndarray, set[str]]]:
        """Each inertial body's load (Fx, Fy, C) as the student's answers give it, and the keys used."""
        out = {}
        for body, b in case.bodies.items():
            force, used = self._force(b, given, ("Fi", "aG"))
            couple, more = self._couple(b, given, ("Ci", "alpha", "h"), force)
            out[body] = (np.array([force[0], force[1], couple]), used | more)
        return out

    def _value(self, a: SolvedAnswer, dep: Dependency, case: _Case, given, loads):
        """(value in SI, keys used) of one carriable answer, or None when nothing upstream was given."""
        i, bp = self.index, self.batch
        asked = _parse(a.of)
        name, comp = asked.quantity.name, asked.component or "mag"
        rng = self.problem.angle_range
        if dep.stage == "inertia":
            b = case.bodies[self.problem.body_of(asked.args)]
            if name == "Fi":
                force, used = self._force(b, given, ("aG",))
                return _component(force, comp, rng), used
            if name == "Ci":
                return self._couple(b, given, ("alpha",), b.force[i])
            force, used = self._force(b, given, ("Fi", "aG"))
            couple, more = self._couple(b, given, ("Ci", "alpha"), force)
            size = float(np.hypot(*force))
            return (abs(couple) / size if size > 0 else 0.0), used | more
        stem = _stem(asked)
        m = case.maps[stem][0][i]
        if asked.group:
            body = case.labels[asked.group][len(_INERTIA):]
            load, used = loads[body]
            vec = m @ case.bodies[body].units[i] @ load
        else:
            parts = bp.parts.get((id(case), stem), {})
            vec = np.zeros(m.shape[0])
            used = set()
            for g, group in enumerate(case.groups):
                label = group_label(self.problem, group)
                own = {c: given[k] for c, k in parts.get(label, {}).items() if k in given}
                if own:  # the student's part
                    exact = m @ case.parts[i, :, g]
                    vec = vec + (_compose(exact, own) if len(vec) == 2 else np.array([own["mag"]]))
                    used |= {parts[label][c] for c in own}
                elif group.startswith(_INERTIA):
                    load, keys = loads[group[len(_INERTIA):]]
                    vec = vec + m @ case.bodies[group[len(_INERTIA):]].units[i] @ load
                    used |= keys
                else:
                    vec = vec + m @ case.parts[i, :, g]
        return (_component(vec, comp, rng) if len(vec) == 2 else float(vec[0])), used
