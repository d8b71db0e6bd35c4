"""Error carried forward: which answers follow from which, and each later answer recomputed from a student's own.

A solved variant (`gradekit.answers.Result`) knows more than its answers: which bodies carry
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
`gradekit.keys.Tolerance`); `credited` lists the answers wrong against the key that match theirs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from gradekit import quantities, units
from gradekit.answers import Answer, Result, flat_results, group_label, wrap
from gradekit.keys import Tolerance
from gradekit.mechanics.forces import Solution, Solutions, spot_point
from gradekit.mechanics.model import Refusals
from gradekit.numbers import fmt

STAGES = ("given", "kinematics", "inertia", "forces", "total")
_STAGE = {
    **dict.fromkeys(("aG", "vG", "a", "v", "alpha", "omega", "theta", "r", "transmission"), "kinematics"),
    **dict.fromkeys(("Fi", "Ci", "h"), "inertia"),
    **dict.fromkeys(("F", "M", "driver", "shaking", "shaking_moment"), "forces"),
    "param": "given",
}
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
        """``consistent with your alpha2 = 480 rad/s² and aG2 = 2.1e+05 mm/s²`` (the wrong values used)."""
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
    tolerances = tolerances or {}
    exact = {a.key: a for a in plan(result).answers}
    out = {}
    for key, c in carried(result, submitted, tolerances).items():
        value = _present(submitted.get(key))
        tol = tolerances.get(key) or exact[key].tolerance
        if value is not None and not tol.accepts(value, exact[key].value) and c.accepts(value, tol):
            out[key] = c
    return out


def plan(result: Result) -> Plan:
    """The carry plan of *result*, made once and kept on it."""
    made = result.__dict__.get("_carry")
    if made is None:
        made = result.__dict__["_carry"] = Plan(result)
    return made


def _present(value) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


@dataclass
class _Source:
    """Answers that give a body's inertia force: ``Fi[k]`` (as is) or its a_G (times −m)."""

    kind: str  # Fi | aG
    keys: dict[str, str]  # component (x, y, mag, angle) -> answer key


@dataclass
class _Body:
    """An inertial body: its exact inertia load, its unit responses and the answers that give its load."""

    mass: float
    inertia: float
    force: np.ndarray  # the exact inertia force −m·a_G (N)
    couple: float  # the exact inertia couple −I·α (N·m)
    units: np.ndarray  # (ncol, 3): the unknowns due to a unit force in x, in y at G and a unit couple
    forces: list[_Source] = field(default_factory=list)  # by preference
    couples: list[tuple[str, str]] = field(default_factory=list)  # (Ci | alpha | h, answer key) by preference

    def keys(self, kinds=("Fi", "aG", "Ci", "alpha", "h")) -> list[str]:
        out = [k for s in self.forces if s.kind in kinds for k in s.keys.values()]
        return out + [k for kind, k in self.couples if kind in kinds]


class _Case:
    """One case (position) of a variant: its solution, the unknowns' responses, the stems' maps."""

    def __init__(self, result: Result, index: int, answers: list[Answer]) -> None:
        problem = result.problem
        case = result.cases[index]
        sol: Solution = case.solution
        if sol.matrix is None or sol.rhs is None:
            raise ValueError("expected a solution with its assembled system (matrix and rhs), got none")
        self.problem, self.case, self.sol = problem, case, sol
        link = sol.linkage
        self.scale = float(link.scale)
        self.groups = list(sol.groups)
        inertial = [g[len(_INERTIA):] for g in self.groups if g.startswith(_INERTIA)]
        A, B = np.asarray(sol.matrix, float), np.asarray(sol.rhs, float)
        nrow = A.shape[0]
        row = {b: 3 * i for i, b in enumerate(link.bodies)}
        E = np.zeros((nrow, 3 * len(inertial)))
        for n, body in enumerate(inertial):
            g = np.asarray(sol.states[body].g, float)
            o = link.bodies[body].origin
            d = g - np.array([float(o.x.v), float(o.y.v)])
            r = row[body]
            E[r : r + 3, 3 * n : 3 * n + 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-d[1], d[0], 1.0]]
        Y = -np.linalg.solve(A, np.hstack([B, E]))
        self.parts = Y[:, : len(self.groups)]  # (ncol, G): each group's unknowns
        self.bodies: dict[str, _Body] = {}
        for n, body in enumerate(inertial):
            st = sol.states[body]
            self.bodies[body] = _Body(
                float(st.mass), float(st.inertia), np.asarray(st.inertia_force, float),
                float(st.inertia_couple), Y[:, len(self.groups) + 3 * n : len(self.groups) + 3 * n + 3],
            )
        self.labels = {group_label(problem, g): g for g in self.groups}
        self._responses: dict[tuple[str, str], np.ndarray] = {}
        self._sources(answers)
        self.maps = self._maps(answers)

    def _sources(self, answers: list[Answer]) -> None:
        """Attach to each inertial body the answers that give its inertia force and couple."""
        problem = self.problem
        found: dict[str, dict[str, dict[str, str]]] = {}
        couples: dict[str, dict[str, str]] = {}
        for a in answers:
            asked = _parse(a.of)
            if asked is None or asked.group:
                continue
            name = asked.quantity.name
            body = problem.body_of(asked.args) if name in ("aG", "Fi", "Ci", "alpha", "h") else None
            if name == "a":
                body = self._body_at(asked.args)
                name = "aG" if body else None
            if body not in self.bodies:
                continue
            if name in ("aG", "Fi"):
                found.setdefault(body, {}).setdefault(name, {}).setdefault(asked.component or "mag", a.key)
            elif name in ("Ci", "alpha", "h"):
                couples.setdefault(body, {}).setdefault(name, a.key)
        order = ("Ci", "h", "alpha") if problem.method == "graphical" else ("Ci", "alpha", "h")
        for body, b in self.bodies.items():
            b.forces = [_Source(kind, found[body][kind]) for kind in ("Fi", "aG") if kind in found.get(body, {})]
            b.couples = [(kind, couples[body][kind]) for kind in order if kind in couples.get(body, {})]

    def _body_at(self, printed: str) -> str | None:
        """The inertial body whose centre of mass is point *printed* (same place and acceleration)."""
        problem, sol = self.problem, self.sol
        link = sol.linkage
        spots = {**link.points, **sol.analysis.points}
        name = next((n for n in spots if problem.point(n) == printed), None)
        if name is None:
            return None
        p = spots[name]
        p = p if hasattr(p, "x") else spot_point(link, p)
        pos = np.array([float(p.x.v), float(p.y.v)])
        acc = np.array([float(p.x.dd), float(p.y.dd)])
        for body in self.bodies:
            st = sol.states[body]
            a_g = np.asarray(st.a_g, float)
            same_place = np.hypot(*(pos - st.g)) <= 1e-9 * self.scale
            same_acc = np.hypot(*(acc - a_g)) <= 1e-9 * max(np.hypot(*acc), np.hypot(*a_g))
            if same_place and same_acc:
                return body
        return None

    def _maps(self, answers: list[Answer]) -> dict[str, tuple[np.ndarray, str]]:
        """Each force stem's (components × unknowns) linear map and SI unit, read off the named
        results of the unit unknowns (so the answers' own definitions, `flat_results`, decide)."""
        stems = {}
        for a in answers:
            asked = _parse(a.of)
            if asked is not None and _STAGE[asked.quantity.name] == "forces":
                stems[_stem(asked)] = asked.quantity.vector
        if not stems:
            return {}
        sol = self.sol
        ncol = self.parts.shape[0]
        unit = Solutions(
            sol.linkage, sol.analysis, (), np.zeros((ncol, ncol, 0)), np.eye(ncol), sol.states, np.zeros(ncol),
            np.zeros(ncol), None, Refusals(ncol), np.zeros(ncol, bool),
        )
        named = flat_results(self.problem, unit, self.case.values)
        out = {}
        for stem, vector in stems.items():
            if vector:
                (x, si), (y, _) = named[stem + ".x"], named[stem + ".y"]
                out[stem] = (np.vstack([x, y]), si)
            else:
                v, si = named[stem]
                out[stem] = (np.asarray(v, float)[None, :], si)
        return out

    def response(self, stem: str, body: str) -> np.ndarray:
        """How *stem* changes with *body*'s inertia load (Fx, Fy, C), unit-free: per newton, a
        couple per newton times the mechanism's scale, a moment answer divided by that scale."""
        key = (stem, body)
        if key not in self._responses:
            m, si = self.maps[stem]
            r = m @ self.bodies[body].units * np.array([1.0, 1.0, self.scale])
            self._responses[key] = r / self.scale if _is_moment(si) else r
        return self._responses[key]


def _is_moment(si: str) -> bool:
    return units.si_unit(si) == units.si_unit("N*m")


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


class Plan:
    """What can be carried in one solved variant, and the recomputation for a student's values."""

    def __init__(self, result: Result) -> None:
        self.result = result
        self.problem = result.problem
        self.answers: list[Answer] = list(result.answers)
        names = [c.name for c in result.cases]
        by_case: dict[int, list[Answer]] = {}
        for a in self.answers:
            by_case.setdefault(names.index(a.case) if a.case in names else 0, []).append(a)
        self.cases = {i: _Case(result, i, by_case[i]) for i in by_case}
        self.case_of = {a.key: self.cases[i] for i, group in by_case.items() for a in group}
        self.si = {a.key: self.case_of[a.key].case.results[a.of][1] for a in self.answers}
        self._part_keys: dict[tuple[int, str], dict[str, dict[str, str]]] = {}
        self._stems: dict[tuple[int, str], tuple] = {}
        self.dependencies = {a.key: self._dependency(a) for a in self.answers}

    # -- dependencies -------------------------------------------------------------------------------

    def _dependency(self, a: Answer) -> Dependency:
        asked = _parse(a.of)
        if asked is None:
            d = quantities.derived(a.of)
            if d is None:
                return Dependency(a.key, "given", reason="a given value: nothing upstream")
            stages = [_STAGE[q.quantity.name] for _p, q, _l in d.refs.values()]
            stage = max(stages, key=STAGES.index)
            return Dependency(a.key, stage, reason="an expression of other results: not carried")
        name = asked.quantity.name
        stage = _STAGE[name]
        case = self.case_of[a.key]
        if stage == "given":
            return Dependency(a.key, stage, reason="a given value: nothing upstream")
        if stage == "kinematics":
            return Dependency(a.key, stage, reason="kinematics: the first stage, computed from the given values only")
        if stage == "inertia":
            return self._inertia_dependency(a, asked, case)
        return self._force_dependency(a, asked, case)

    def _inertia_dependency(self, a: Answer, asked, case: _Case) -> Dependency:
        name = asked.quantity.name
        body = self.problem.body_of(asked.args)
        b = case.bodies.get(body)
        want = {"Fi": ("aG",), "Ci": ("alpha",), "h": ("Fi", "aG", "Ci", "alpha")}[name]
        upstream = tuple(b.keys(want)) if b is not None else ()
        if not upstream:
            needs = {"Fi": "a_G", "Ci": "α", "h": "its inertia force and couple (or a_G and α)"}[name]
            return Dependency(a.key, "inertia", reason=f"its upstream ({needs} of link {asked.args}) is not asked")
        return Dependency(a.key, "inertia", upstream)

    def _force_dependency(self, a: Answer, asked, case: _Case) -> Dependency:
        stem = _stem(asked)
        if asked.group:
            group = case.labels.get(asked.group, asked.group)
            if not group.startswith(_INERTIA):
                why = f"a part due to {asked.group}, a given load: nothing upstream"
                return Dependency(a.key, "forces", reason=why)
            body = group[len(_INERTIA):]
            keys = self._body_keys(case, stem, body)
            if not keys:
                return Dependency(a.key, "forces", reason=f"its upstream (the kinematics or inertia of link "
                                  f"{self.problem.label(body)}) is not asked")
            return Dependency(a.key, "forces", tuple(keys))
        stage, upstream, held, reason = self._stem_dependency(case, stem)
        return Dependency(a.key, stage, upstream, held, reason)

    def _stem_dependency(self, case: _Case, stem: str) -> tuple[str, tuple[str, ...], tuple[str, ...], str]:
        """(stage, upstream, held, reason) of a total *stem*, shared by its components."""
        key = (id(case), stem)
        if key in self._stems:
            return self._stems[key]
        parts = self._parts(case, stem)
        upstream: list[str] = [k for comps in parts.values() for k in comps.values()]
        held = []
        m, _ = case.maps[stem]
        each = np.abs(m @ case.parts).max(axis=0)  # what each group does to the stem
        size = max(float(np.abs(m @ case.parts.sum(axis=1)).max()), float(each.max(initial=0.0)), 1e-300)
        for g, group in enumerate(case.groups):
            label = group_label(self.problem, group)
            if label in parts or each[g] <= _ZERO * size:
                continue
            keys = self._body_keys(case, stem, group[len(_INERTIA):]) if group.startswith(_INERTIA) else []
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
        self._stems[key] = (stage, tuple(upstream), tuple(held), reason)
        return self._stems[key]

    def _parts(self, case: _Case, stem: str) -> dict[str, dict[str, str]]:
        """The asked superposition parts of *stem*: group label -> component -> answer key."""
        if (id(case), stem) not in self._part_keys:
            out: dict[str, dict[str, str]] = {}
            for a in self.answers:
                asked = _parse(a.of)
                if asked is not None and asked.group and self.case_of[a.key] is case and _stem(asked) == stem:
                    out.setdefault(asked.group, {}).setdefault(asked.component or "mag", a.key)
            self._part_keys[(id(case), stem)] = out
        return self._part_keys[(id(case), stem)]

    def _body_keys(self, case: _Case, stem: str, body: str) -> list[str]:
        """The answers giving *body*'s inertia load that *stem* responds to (by what each one moves)."""
        b = case.bodies[body]
        ref = b.force if np.hypot(*b.force) > 0 else np.array([1.0, 0.0])
        u = ref / np.hypot(*ref)
        moves = {
            "x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]),
            "mag": np.array([u[0], u[1], 0.0]), "angle": np.array([-u[1], u[0], 0.0]),
        }
        r = case.response(stem, body)
        couple = bool(np.abs(r[:, 2]).max() > _ZERO)
        by_h = any(kind == "h" for kind, _ in b.couples)  # a couple from an offset is h·|F|
        out = []
        for s in b.forces:
            for comp, key in s.keys.items():
                if b.mass and (np.abs(r @ moves[comp]).max() > _ZERO or (by_h and couple)):
                    out.append(key)
        out += [key for kind, key in b.couples if couple and (kind != "alpha" or b.inertia) and (kind != "h" or b.mass)]
        return out

    # -- recomputation ------------------------------------------------------------------------------

    def carried(
        self, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
    ) -> dict[str, Carried]:
        """See `carried`: the recomputed answers with at least one wrong upstream value."""
        tolerances = tolerances or {}
        return {k: c for k, c in self.recompute(submitted, tolerances).items() if c.wrong}

    def recompute(
        self, submitted: Mapping[str, float], tolerances: Mapping[str, Tolerance] | None = None
    ) -> dict[str, Carried]:
        """Every carriable answer recomputed from the student's upstream values present in
        *submitted* (their wrong ones or not), each with the values it used."""
        tolerances = tolerances or {}
        exact = {a.key: a for a in self.answers}
        needed = {k for d in self.dependencies.values() for k in d.upstream}
        given: dict[str, float] = {}  # SI (degrees for angles)
        used_of: dict[str, Used] = {}
        for key in needed:
            value = _present(submitted.get(key))
            if value is None:
                continue
            a = exact[key]
            given[key] = units.convert(value, a.unit, self.si[key])
            tol = tolerances.get(key) or a.tolerance
            used_of[key] = Used(key, value, a.unit, not tol.accepts(value, a.value))
        out = {}
        loads = {id(case): self._loads(case, given) for case in self.cases.values()}
        for a in self.answers:
            dep = self.dependencies[a.key]
            if not dep.carriable:
                continue
            case = self.case_of[a.key]
            got = self._value(a, dep, case, given, loads[id(case)])
            if got is None:
                continue
            value, keys = got
            keys = [k for k in dep.upstream if k in keys]
            if not keys:
                continue
            value = units.convert(value, self.si[a.key], a.unit)
            tol = tolerances.get(a.key) or a.tolerance
            out[a.key] = Carried(a.key, float(value), a.unit, tuple(used_of[k] for k in keys), tol)
        return out

    def _force(self, b: _Body, given: dict[str, float], kinds: tuple[str, ...]) -> tuple[np.ndarray, set[str]]:
        """*b*'s inertia force from the student's answers of *kinds* (the first source they gave sets
        whether it is read by magnitude and direction or by components), the rest exact."""
        present = []
        for s in b.forces:
            comps = {c: k for c, k in s.keys.items() if k in given}
            if s.kind in kinds and comps:
                present.append((s, comps))
        if not present:
            return b.force, set()
        polar = bool({"mag", "angle"} & set(present[0][1]))
        got: dict[str, float] = {}
        used = set()
        for s, comps in present:
            for c, k in comps.items():
                if c in got or (c in ("mag", "angle")) != polar:
                    continue
                v = given[k]
                if s.kind == "aG":
                    v = v + 180.0 if c == "angle" else (b.mass * v if c == "mag" else -b.mass * v)
                got[c] = v
                used.add(k)
        return _compose(b.force, got), used

    def _couple(self, b: _Body, given: dict[str, float], kinds: tuple[str, ...], force: np.ndarray):
        """*b*'s inertia couple from the first of the student's answers of *kinds* given (an offset h
        with the sense of their α, else of the exact couple), exact when none is."""
        alpha = next((k for kind, k in b.couples if kind == "alpha" and k in given), None)
        for kind, key in b.couples:
            if kind not in kinds or key not in given:
                continue
            if kind == "Ci":
                return given[key], {key}
            if kind == "alpha":
                return -b.inertia * given[key], {key}
            if b.mass:  # h: |C| = h·|F|, on the side the couple turns
                sense = -b.inertia * given[alpha] if alpha is not None and "alpha" in kinds else b.couple
                return math.copysign(given[key] * float(np.hypot(*force)), sense or 1.0), {key} | (
                    {alpha} if alpha is not None and "alpha" in kinds else set())
        return b.couple, set()

    def _loads(self, case: _Case, given: dict[str, float]) -> dict[str, tuple[np.ndarray, set[str]]]:
        """Each inertial body's load (Fx, Fy, C) as the student's answers give it, and the keys used."""
        out = {}
        for body, b in case.bodies.items():
            force, used = self._force(b, given, ("Fi", "aG"))
            couple, more = self._couple(b, given, ("Ci", "alpha", "h"), force)
            out[body] = (np.array([force[0], force[1], couple]), used | more)
        return out

    def _value(self, a: Answer, dep: Dependency, case: _Case, given, loads):
        """(value in SI, keys used) of one carriable answer, or None when nothing upstream was given."""
        asked = _parse(a.of)
        name, comp = asked.quantity.name, asked.component
        rng = self.problem.angle_range
        if dep.stage == "inertia":
            b = case.bodies[self.problem.body_of(asked.args)]
            if name == "Fi":
                force, used = self._force(b, given, ("aG",))
                return (_component(force, comp or "mag", rng), used) if used else None
            if name == "Ci":
                couple, used = self._couple(b, given, ("alpha",), b.force)
                return (couple, used) if used else None
            force, used = self._force(b, given, ("Fi", "aG"))
            couple, more = self._couple(b, given, ("Ci", "alpha"), force)
            size = float(np.hypot(*force))
            h = abs(couple) / size if size > 0 else 0.0
            return (h, used | more) if used | more else None
        stem = _stem(asked)
        m, _si = case.maps[stem]
        used: set[str] = set()
        if asked.group:
            body = case.labels[asked.group][len(_INERTIA):]
            load, used = loads[body]
            vec = m @ case.bodies[body].units @ load
        else:
            parts = self._parts(case, stem)
            vec = np.zeros(m.shape[0])
            for g, group in enumerate(case.groups):
                label = group_label(self.problem, group)
                own = {c: given[k] for c, k in parts.get(label, {}).items() if k in given}
                if own:
                    exact = m @ case.parts[:, g]
                    vec = vec + (_compose(exact, own) if m.shape[0] == 2 else np.array([own.get("mag", exact[0])]))
                    used |= {parts[label][c] for c in own}
                elif group.startswith(_INERTIA):
                    load, keys = loads[group[len(_INERTIA):]]
                    vec = vec + m @ case.bodies[group[len(_INERTIA):]].units @ load
                    used |= keys
                else:
                    vec = vec + m @ case.parts[:, g]
        if not used:
            return None
        return (_component(vec, comp or "mag", rng) if m.shape[0] == 2 else float(vec[0])), used
