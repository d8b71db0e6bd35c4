"""The problem file format, validated field by field into the frozen records of `gradekit.bank.model`.

Every mapping is checked for unknown keys (a misspelt ``tolerence:`` is an error, never a silent
default); every error is collected as ``file:line: field: expected …, got …`` and reported
together. See ``problem_bank/README.md`` for the format documented field by field.
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from typing import Any

from gradekit import units
from gradekit.bank import expr
from gradekit.bank.measured import MEASURED, apply_measured, measured_tolerances  # noqa: F401
from gradekit.bank.model import (
    _ID,
    ANALYSES,
    DEFINED,
    DIMENSIONS,
    GRADABLE,
    LOAD_KEYS,
    LOAD_TYPES,
    METHODS,
    SHOW,
    UNIT_SYSTEMS,
    AnswerSpec,
    Constraints,
    Figure,
    LoadSpec,
    MassSpec,
    Parameter,
    PointSpec,
    Problem,
    Published,
    Value,
    order,
)
from gradekit.bank.yamlfile import LineDict, LineList
from gradekit.errors import ErrorList, GradekitError, ProblemError
from gradekit.mechanics.mechanisms import KINDS
from gradekit.solving import quantities, tolerances
from gradekit.solving.keys import Tolerance


class _Collector:
    """Collects validation errors with their lines."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.errors: list[GradekitError] = []

    def err(self, node: Any, key: Any, fieldname: str, message: str) -> None:
        line = None
        if isinstance(node, LineDict):
            line = node.lines.get(key, node.line)
        elif isinstance(node, LineList) and isinstance(key, int) and key < len(node.lines):
            line = node.lines[key]
        elif isinstance(node, (LineDict, LineList)):
            line = node.line
        self.errors.append(ProblemError(message, path=self.path, line=line, field=fieldname))

    def mapping(
        self,
        node: Any,
        where: str,
        required: tuple[str, ...],
        optional: tuple[str, ...],
        parent: Any = None,
        key: Any = None,
    ) -> LineDict | None:
        if not isinstance(node, dict):
            self.err(parent, key, where, f"expected a mapping, got {_show(node)}")
            return None
        for k in node:
            if k not in required and k not in optional:
                allowed = ", ".join(sorted(required + optional))
                near = difflib.get_close_matches(str(k), list(required + optional), n=1, cutoff=0.75)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", str(k)):
                    hint += (" (in a flow mapping {…} a comma ends the value: quote a value that has a comma, "
                             "e.g. description: \"load, along −x\")")
                self.err(
                    node, k, f"{where}.{k}" if where else str(k),
                    f"expected one of {allowed}; got unknown key {k!r}{hint}",
                )
        for k in required:
            if k not in node:
                self.err(node, None, f"{where}.{k}" if where else k, "expected this field, got nothing")
        return node

    def text(self, node: dict, key: str, where: str, default: str | None = None) -> str:
        v = node.get(key, default)
        if not isinstance(v, str):
            self.err(node, key, where, f"expected text, got {_show(v)}")
            return default or ""
        return v

    def number(
        self, node: dict, key: str, where: str, default: float | None = None, positive: bool = False
    ) -> float | None:
        v = node.get(key, default)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.err(node, key, where, f"expected a number, got {_show(v)}")
            return default
        if positive and v <= 0:
            self.err(node, key, where, f"expected a number greater than 0, got {v}")
        return float(v)

    def choice(self, node: dict, key: str, where: str, options: tuple[str, ...], default: str) -> str:
        v = node.get(key, default)
        if v not in options:
            self.err(node, key, where, f"expected one of {', '.join(options)}; got {_show(v)}")
            return default
        return v

    def unit(self, node: dict, key: str, where: str, default: str | None = None) -> str:
        v = node.get(key, default)
        if not isinstance(v, str):
            self.err(node, key, where, f"expected a unit such as mm or N*m, got {_show(v)}")
            return default or ""
        try:
            units.check(v)
        except GradekitError as exc:
            self.err(node, key, where, exc.detail)
        return v


def _show(v: Any) -> str:
    if v is None:
        return "nothing"
    text = repr(v)
    return text if len(text) < 60 else text[:57] + "..."


def _value(
    c: _Collector, node: dict, key: str, where: str, names: set[str], default: Value | None = None
) -> Value | None:
    """A field that is a number, a parameter name or an expression over parameters."""
    v = node.get(key, default)
    if v is None:
        return None
    if isinstance(v, bool):
        c.err(node, key, where, f"expected a number or parameter expression, got {v!r}")
        return default
    if isinstance(v, (int, float)):
        return float(v)
    if isinstance(v, str):
        try:
            unknown = expr.names(v) - names
        except expr.ExprError as exc:
            c.err(node, key, where, str(exc))
            return default
        if unknown:
            c.err(
                node,
                key,
                where,
                f"expected parameters among {', '.join(sorted(names))}; "
                f"got unknown name(s) {', '.join(sorted(unknown))}",
            )
        return v
    c.err(node, key, where, f"expected a number or parameter expression, got {_show(v)}")
    return default


def _parameters(c: _Collector, node: Any, parent: dict) -> dict[str, Parameter]:
    out: dict[str, Parameter] = {}
    if not isinstance(node, dict):
        c.err(parent, "parameters", "parameters", f"expected a mapping of name: definition, got {_show(node)}")
        return out
    for name, spec in node.items():
        w = f"parameters.{name}"
        if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", str(name)) or name in expr.FUNCTIONS or name == "pi":
            c.err(node, name, w, f"expected a name of letters, digits and _ (not a function), got {name!r}")
            continue
        if isinstance(spec, (int, float)) and not isinstance(spec, bool):
            c.err(node, name, w, "expected a mapping with value and unit, got a bare number")
            continue
        m = c.mapping(
            spec,
            w,
            ("unit",),
            ("value", "range", "step", "sigfigs", "choices", "expr", "symbol", "description", "decimals"),
            node,
            name,
        )
        if m is None:
            continue
        unit = c.unit(m, "unit", f"{w}.unit")
        value = c.number(m, "value", f"{w}.value")
        low = high = None
        if "range" in m:
            r = m["range"]
            if (
                not isinstance(r, list)
                or len(r) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in r)
            ):
                c.err(m, "range", f"{w}.range", f"expected [min, max], got {_show(r)}")
            elif not r[1] > r[0]:
                c.err(m, "range", f"{w}.range", f"expected max greater than min ({r[0]}), got {r[1]}")
            else:
                low, high = float(r[0]), float(r[1])
        step = c.number(m, "step", f"{w}.step", positive=True)
        sig = m.get("sigfigs")
        if sig is not None and (not isinstance(sig, int) or isinstance(sig, bool) or not 1 <= sig <= 8):
            c.err(m, "sigfigs", f"{w}.sigfigs", f"expected a whole number from 1 to 8, got {_show(sig)}")
            sig = None
        choices: tuple[float, ...] = ()
        if "choices" in m:
            ch = m["choices"]
            if (
                not isinstance(ch, list)
                or not ch
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in ch)
            ):
                c.err(m, "choices", f"{w}.choices", f"expected a list of numbers, got {_show(ch)}")
            else:
                choices = tuple(float(x) for x in ch)
        ex = m.get("expr")
        if ex is not None:
            if not isinstance(ex, str):
                c.err(m, "expr", f"{w}.expr", f"expected an expression, got {_show(ex)}")
                ex = None
            else:
                try:
                    expr.parse(ex)
                except expr.ExprError as exc:
                    c.err(m, "expr", f"{w}.expr", str(exc))
                    ex = None
        kinds = sum(x is not None and x != () for x in (low, choices or None, ex))
        if kinds > 1:
            c.err(m, None, w, "expected only one of range, choices or expr")
        if low is not None and step is None and sig is None:
            c.err(m, "range", w, "expected step or sigfigs with range (values are rounded as printed)")
        if ex is None and value is None:
            c.err(m, None, f"{w}.value", "expected the published (fixed) value, got nothing")
        if value is not None and low is not None and not low <= value <= high:
            c.err(m, "value", f"{w}.value", f"expected the published value inside range [{low}, {high}], got {value}")
        dec = m.get("decimals")
        if dec is not None and (not isinstance(dec, int) or isinstance(dec, bool) or not 0 <= dec <= 8):
            c.err(m, "decimals", f"{w}.decimals", f"expected a whole number from 0 to 8, got {_show(dec)}")
            dec = None
        out[name] = Parameter(
            name,
            unit,
            value,
            low,
            high,
            step,
            sig,
            choices,
            ex,
            str(m.get("symbol", "")),
            str(m.get("description", "")),
            dec,
        )
    # derived parameters may only refer to defined names, without cycles
    for p in out.values():
        if p.expr:
            unknown = expr.names(p.expr) - set(out)
            if unknown:
                c.err(
                    node[p.name],
                    "expr",
                    f"parameters.{p.name}.expr",
                    f"expected parameters among {', '.join(sorted(out))}; got unknown {', '.join(sorted(unknown))}",
                )
    try:
        order(out)
    except ValueError as exc:
        c.err(node, None, "parameters", str(exc))
    return out


def _tolerance(c: _Collector, node: Any, where: str, default: Tolerance, parent: dict) -> Tolerance:
    if node is None:
        return default
    m = c.mapping(node, where, (), ("mode", "rel", "abs", "sigfigs", "floor"), parent, "tolerance")
    if m is None:
        return default
    mode = c.choice(m, "mode", f"{where}.mode", ("relative", "sigfigs"), default.mode)
    rel = c.number(m, "rel", f"{where}.rel", default.rel)
    ab = c.number(m, "abs", f"{where}.abs", default.abs)
    sig = m.get("sigfigs", default.sigfigs)
    if not isinstance(sig, int) or isinstance(sig, bool) or not 1 <= sig <= 8:
        c.err(m, "sigfigs", f"{where}.sigfigs", f"expected a whole number from 1 to 8, got {_show(sig)}")
        sig = default.sigfigs
    if rel is not None and not 0 <= rel < 1:
        c.err(m, "rel", f"{where}.rel", f"expected a fraction from 0 to 1 (0.01 = 1 %), got {rel}")
    if ab is not None and ab < 0:
        c.err(m, "abs", f"{where}.abs", f"expected a number of at least 0, got {ab}")
    fl = c.number(m, "floor", f"{where}.floor", default.floor)
    if fl is not None and not 0 <= fl < 1:
        c.err(m, "floor", f"{where}.floor", f"expected a fraction of the answer scale from 0 to 1, got {fl}")
    return Tolerance(mode, rel or 0.0, ab or 0.0, sig, fl or 0.0, default.period)


TOP_REQUIRED = ("id", "title", "source", "method", "analysis", "mechanism", "parameters", "statement", "answers")
TOP_OPTIONAL = (
    "tags",
    "units",
    "loads",
    "mass",
    "gravity",
    "weight_g",
    "constraints",
    "cases",
    "published",
    "figure",
    "notes",
    "origin",
    "angle_range",
    "sigfigs",
)


def validate(data: dict, path: str) -> Problem:
    """Validate one problem mapping (from `yamlfile.load`); raise `ErrorList` with every error."""
    c = _Collector(path)
    top = c.mapping(data, "", TOP_REQUIRED, TOP_OPTIONAL)
    if top is None:
        raise ErrorList(c.errors)
    pid = data.get("id")
    if not isinstance(pid, str) or not _ID.match(pid):
        c.err(data, "id", "id", f"expected lower-case letters, digits, _ and -, got {_show(pid)}")
        pid = str(pid)
    title = c.text(data, "title", "title", "")
    src = c.mapping(data.get("source"), "source", ("document", "ref"), ("seed", "note"), data, "source") or {}
    source = {k: str(v) for k, v in src.items()}
    tags = data.get("tags", [])
    if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
        c.err(data, "tags", "tags", f"expected a list of words, got {_show(tags)}")
        tags = []
    method = c.choice(data, "method", "method", METHODS, "analytical")
    analysis = c.choice(data, "analysis", "analysis", ANALYSES, "static")
    dims = _units(c, data)

    params = _parameters(c, data.get("parameters"), data)
    names = set(params)

    mech = (
        c.mapping(
            data.get("mechanism"),
            "mechanism",
            ("type", "geometry", "input"),
            ("branch", "driver", "labels", "points"),
            data,
            "mechanism",
        )
        or LineDict()
    )
    kind = mech.get("type")
    spec = KINDS.get(kind) if isinstance(kind, str) else None
    if spec is None and "type" in mech:
        near = difflib.get_close_matches(str(kind), list(KINDS), n=1, cutoff=0.5)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        c.err(mech, "type", "mechanism.type", f"expected one of {', '.join(KINDS)}; got {_show(kind)}{hint}")
    br = mech.get("branch", "open")
    branch = {"open": 1, "crossed": -1, 1: 1, -1: -1}.get(br) if not isinstance(br, bool) else None
    if branch is None:
        c.err(mech, "branch", "mechanism.branch", f"expected open, crossed, 1 or -1; got {_show(br)}")
        branch = 1
    drivers = spec.drivers if spec else ("crank",)
    driver = c.choice(mech, "driver", "mechanism.driver", drivers, "crank")
    bodies = ("ground",) + (spec.bodies if spec else ())
    labels = _names_map(c, mech, "labels", bodies) if spec else {}
    point_names, point_nodes = _point_names(c, mech, spec.points if spec else ()) if spec else ({}, {})
    geometry: dict[str, Value] = {}
    g = (
        c.mapping(mech.get("geometry"), "mechanism.geometry", spec.required, tuple(spec.optional), mech, "geometry")
        if spec
        else None  # an unknown type: one error above, not one per geometry key
    )
    for k in g or {}:
        v = _value(c, g, k, f"mechanism.geometry.{k}", names)
        if v is not None:
            geometry[k] = v
    inp = c.mapping(mech.get("input"), "mechanism.input", ("theta",), ("omega", "alpha"), mech, "input") or {}
    inputs = {k: v for k in inp if (v := _value(c, inp, k, f"mechanism.input.{k}", names)) is not None}
    if analysis == "dynamic" and "omega" not in inputs:
        c.err(inp, None, "mechanism.input.omega", "expected the crank speed for a dynamic analysis, got nothing")
    moving_loads = [ld.get("type") for ld in data.get("loads", []) or [] if isinstance(ld, dict)
                    and ld.get("type", "force") != "force"]
    if moving_loads and "omega" not in inputs:
        c.err(inp, None, "mechanism.input.omega",
              f"expected the crank speed: a {moving_loads[0]} load depends on the motion, got nothing")

    body_names = set(spec.bodies) if spec else set()
    point_set = set(spec.points) if spec else set()
    shown = {name: point_names.get(name, name) for name in point_set}  # internal -> printed name
    defined = _defined_points(c, mech, point_nodes, names, shown, labels, body_names)
    shown.update({k: d.name for k, d in defined.items()})
    carried = _carriers(kind, defined) if spec else {}
    loads = _loads(c, data, names, body_names, shown, labels, carried) if spec else ()
    mass = _mass(c, data, names, body_names, shown) if spec else ()
    for ms in mass:
        if ms.at.startswith(DEFINED) and carried.get(ms.at) != (ms.body,):
            c.err(data.get("mass", {}).get(ms.body), "at", f"mass.{ms.body}.at",
                  f"expected a point of the {ms.body} (point {ms.at[1:]} is defined on the {carried[ms.at][0]})")
    origin = _point(c, data, "origin", shown, key="origin") if spec else ""
    angle_range = _angle_range(c, data)
    gravity = None
    if "gravity" in data:
        gm = c.mapping(data["gravity"], "gravity", ("g",), ("angle",), data, "gravity") or {}
        gravity = {k: v for k in gm if (v := _value(c, gm, k, f"gravity.{k}", names)) is not None}
        gravity.setdefault("angle", -90.0)
    weight_g = _value(c, data, "weight_g", "weight_g", names) if "weight_g" in data else None
    if any(m.weight is not None for m in mass) and weight_g is None and gravity is None:
        c.err(data, "mass", "weight_g", "expected weight_g (or gravity) to turn weights into masses, got nothing")

    constraints = _constraints(c, data, names)
    cases = _cases(c, data, names)
    statement = c.text(data, "statement", "statement", "")
    answers = _answers(c, data, method, cases)
    if spec:
        _check_asked(c, data, answers, labels, shown, {ld.name for ld in loads}, names, kind)
    published = _published(c, data, _answer_keys(answers, cases), cases)
    figure = _figure(c, data)
    notes = data.get("notes", "")
    if not isinstance(notes, str):
        c.err(data, "notes", "notes", f"expected text, got {_show(notes)}")
        notes = ""
    sigfigs = data.get("sigfigs", 3)
    if not isinstance(sigfigs, int) or isinstance(sigfigs, bool) or not 2 <= sigfigs <= 6:
        c.err(data, "sigfigs", "sigfigs", f"expected a whole number of significant figures from 2 to 6, "
              f"got {_show(sigfigs)}")
        sigfigs = 3
    if c.errors:
        raise ErrorList(c.errors)
    lines = {k: data.lines.get(k, 0) for k in data} if isinstance(data, LineDict) else {}
    return Problem(
        pid,
        title,
        source,
        tuple(tags),
        method,
        analysis,
        dims,
        kind,
        branch,
        driver,
        labels,
        point_names,
        geometry,
        inputs,
        params,
        loads,
        mass,
        gravity,
        weight_g,
        constraints,
        cases,
        statement,
        answers,
        published,
        figure,
        notes,
        path,
        lines,
        origin,
        defined,
        angle_range,
        _field_lines(data),
        sigfigs,
    )


def _names_map(c: _Collector, mech: dict, key: str, allowed: tuple[str, ...]) -> dict[str, str]:
    node = mech.get(key, {})
    m = c.mapping(node, f"mechanism.{key}", (), allowed, mech, key) or {}
    return {k: str(v) for k, v in m.items()}


def _point_names(c: _Collector, mech: dict, kind_points: tuple[str, ...]) -> tuple[dict[str, str], dict]:
    """``mechanism.points``: a kind's point renamed for print (``O2: A``), or a new point defined on a
    body (``P: {on: coupler, from: B, along: 50, perp: 10}``)."""
    node = mech.get("points", {})
    if not isinstance(node, dict):
        c.err(mech, "points", "mechanism.points", f"expected a mapping of point: name or definition, got {_show(node)}")
        return {}, {}
    renamed, defined = {}, {}
    for k, v in node.items():
        if isinstance(v, dict):
            defined[str(k)] = v
        elif k in kind_points:
            renamed[k] = str(v)
        else:
            c.err(node, k, f"mechanism.points.{k}",
                  f"expected one of the kind's points ({', '.join(kind_points)}) renamed, or a new point defined "
                  f"as {{on: <body>, from: <point>, along: <length>, perp: <length>}}; got {k!r}: {_show(v)}")
    return renamed, defined


def _defined_points(c, mech, nodes: dict, names: set[str], shown: dict[str, str], labels: dict[str, str],
                    bodies: set[str]) -> dict[str, PointSpec]:
    out: dict[str, PointSpec] = {}
    pnode = mech.get("points", {})
    for printed, spec in nodes.items():
        w = f"mechanism.points.{printed}"
        if printed in shown.values():
            c.err(pnode, printed, w, f"expected a new point name, got {printed!r}, which the mechanism prints already")
            continue
        if isinstance(spec, LineDict) and True in spec:  # YAML 1.1 reads a bare `on` key as true
            fixed = LineDict()
            fixed.line = spec.line
            for k, v in spec.items():
                fixed["on" if k is True else k] = v
                fixed.lines["on" if k is True else k] = spec.lines.get(k, spec.line)
            spec = fixed
        m = c.mapping(spec, w, ("on", "from"), ("along", "perp"), pnode, printed)
        if m is None or "on" not in m:
            continue
        body = _body_named(c, m, "on", f"{w}.on", bodies, labels, ground=True)
        at = _point(c, m, f"{w}.from", shown, key="from")
        out[DEFINED + printed] = PointSpec(
            printed, body, at, _value(c, m, "along", f"{w}.along", names, 0.0) or 0.0,
            _value(c, m, "perp", f"{w}.perp", names, 0.0) or 0.0,
        )
    return out


def _carriers(kind: str, defined: dict[str, PointSpec]) -> dict[str, tuple[str, ...]]:
    """Which bodies each point is fixed on: the kind's (from the registry) and the author's own."""
    from gradekit.mechanics.mechanisms import carriers

    return {**carriers(kind), **{k: (d.body,) for k, d in defined.items()}}


def _units(c: _Collector, data: dict) -> dict[str, str]:
    """``units:``: a preset name (SI, mm-N-s, in-lbf-s, ft-lbf-s), or a mapping per dimension, which may
    start from a preset with ``system:``."""
    node = data.get("units", {})
    systems = ", ".join(UNIT_SYSTEMS)
    if isinstance(node, str):
        if node not in UNIT_SYSTEMS:
            near = difflib.get_close_matches(node, list(UNIT_SYSTEMS), n=1, cutoff=0.4)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            c.err(data, "units", "units", f"expected a unit system among {systems} or a mapping; got {node!r}{hint}")
            return dict(DIMENSIONS)
        return dict(UNIT_SYSTEMS[node])
    m = c.mapping(node, "units", (), ("system", *DIMENSIONS), data, "units") or {}
    dims = dict(DIMENSIONS)
    if "system" in m:
        if m["system"] in UNIT_SYSTEMS:
            dims = dict(UNIT_SYSTEMS[m["system"]])
        else:
            c.err(m, "system", "units.system", f"expected one of {systems}; got {_show(m['system'])}")
    for k in m:
        if k in DIMENSIONS:
            dims[k] = c.unit(m, k, f"units.{k}")
    return dims


def _angle_range(c: _Collector, data: dict) -> tuple[float, float]:
    r = data.get("angle_range", [0, 360])
    if r in ([0, 360], [-180, 180]):
        return (float(r[0]), float(r[1]))
    c.err(data, "angle_range", "angle_range", f"expected [0, 360] or [-180, 180], got {_show(r)}")
    return (0.0, 360.0)


def _field_lines(data: Any) -> dict[str, int]:
    """Every field's line, by its dotted name (``loads[0].c``), so errors raised after validation
    (while solving) still name the line."""
    out: dict[str, int] = {}

    def walk(node: Any, prefix: str) -> None:
        if isinstance(node, LineDict):
            for k, v in node.items():
                name = f"{prefix}.{k}" if prefix else str(k)
                out[name] = node.lines.get(k, node.line)
                walk(v, name)
        elif isinstance(node, LineList):
            for i, v in enumerate(node):
                name = f"{prefix}[{i}]"
                out[name] = node.lines[i] if i < len(node.lines) else node.line
                walk(v, name)

    walk(data, "")
    answers = data.get("answers") if isinstance(data, dict) else None
    for i, a in enumerate(answers if isinstance(answers, list) else []):
        if isinstance(a, dict) and isinstance(a.get("key"), str):  # answers.<key>.of as the pipeline names it
            for k in a:
                if f"answers[{i}].{k}" in out:
                    out[f"answers.{a['key']}.{k}"] = out[f"answers[{i}].{k}"]
    return out


def _loads(
    c: _Collector,
    data: dict,
    names: set[str],
    bodies: set[str],
    points: dict[str, str],
    labels: dict[str, str],
    carried: dict[str, tuple[str, ...]],
) -> tuple[LoadSpec, ...]:
    node = data.get("loads", [])
    if not isinstance(node, list):
        c.err(data, "loads", "loads", f"expected a list of loads, got {_show(node)}")
        return ()
    out = []
    seen: set[str] = set()
    for i, item in enumerate(node):
        w = f"loads[{i}]"
        typ = item.get("type", "force") if isinstance(item, dict) else "force"
        if typ not in LOAD_TYPES:
            near = difflib.get_close_matches(str(typ), LOAD_TYPES, n=1, cutoff=0.5)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            c.err(item, "type", f"{w}.type", f"expected one of {', '.join(LOAD_TYPES)}; got {_show(typ)}{hint}")
            continue
        required = {"force": ("name", "body"), "damper": ("name", "type", "between", "c"),
                    "spring": ("name", "type", "between", "k"), "rotary_damper": ("name", "type", "link", "c"),
                    "resistance": ("name", "type", "at", "magnitude")}[typ]
        optional = tuple(k for k in ("type", "body", *LOAD_KEYS[typ]) if k not in required)
        m = c.mapping(item, w, required, optional, node, i)
        if m is None:
            continue
        name = c.text(m, "name", f"{w}.name", "")
        if name in seen:
            c.err(m, "name", f"{w}.name", f"expected a unique load name, got {name!r} twice")
        seen.add(name)
        if typ != "force":
            spec = _motion_load(c, m, w, typ, name, names, bodies, points, labels, carried)
            if spec is not None:
                out.append(spec)
            continue
        body = m.get("body")
        if body not in bodies:
            c.err(m, "body", f"{w}.body", f"expected one of {', '.join(sorted(bodies))}; got {_show(body)}")
        at = _point(c, m, f"{w}.at", points)
        _same_body(c, m, f"{w}.at", at, str(body), carried)
        vals = {
            k: _value(c, m, k, f"{w}.{k}", names)
            for k in ("along", "across", "magnitude", "angle", "fx", "fy", "torque")
        }
        has_polar = vals["magnitude"] is not None
        has_xy = vals["fx"] is not None or vals["fy"] is not None
        if has_polar and has_xy:
            c.err(m, "magnitude", w, "expected magnitude and angle, or fx and fy, not both")
        if has_polar and vals["angle"] is None:
            c.err(m, "magnitude", f"{w}.angle", "expected the direction angle with magnitude, got nothing")
        if not (has_polar or has_xy or vals["torque"] is not None):
            c.err(m, None, w, "expected a force (magnitude+angle or fx/fy) or a torque, got neither")
        rel = m.get("relative_angle", False)
        if not isinstance(rel, bool):
            c.err(m, "relative_angle", f"{w}.relative_angle", f"expected true or false, got {_show(rel)}")
            rel = False
        out.append(
            LoadSpec(
                name,
                str(body),
                str(at),
                vals["along"] or 0.0,
                vals["across"] or 0.0,
                vals["magnitude"],
                vals["angle"],
                rel,
                vals["fx"],
                vals["fy"],
                vals["torque"],
            )
        )
    return tuple(out)


def _same_body(c: _Collector, m: dict, where: str, at: str, body: str, carried: dict) -> None:
    """An author-defined point is fixed on one body: what acts there must act on that body."""
    if at.startswith(DEFINED) and carried.get(at) and body not in carried[at]:
        c.err(m, "at", where, f"expected a point of the {body} (point {at[1:]} is defined on the {carried[at][0]})")


def _body_named(c: _Collector, m: dict, key: str, where: str, bodies: set[str], labels: dict[str, str],
                ground: bool = False) -> str:
    """A body given by its name (``coupler``) or its label (``3``)."""
    v = m.get(key)
    by_label = {str(lab): b for b, lab in labels.items()}
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = str(int(v)) if float(v).is_integer() else str(v)
    if v in bodies or (ground and v == "ground"):
        return str(v)
    if isinstance(v, str) and v in by_label and (ground or by_label[v] != "ground"):
        return by_label[v]
    allowed = sorted(bodies | ({"ground"} if ground else set())) + sorted(by_label)
    c.err(m, key, where, f"expected a body or its label among {', '.join(allowed)}; got {_show(m.get(key))}")
    return ""


def _end_body(c, m, where: str, point: str, given: str | None, carried: dict, ground_ok: bool) -> str:
    """The body a point load acts on: given, the point's own body, else the one the point is on."""
    on = carried.get(point, ())
    if given:
        if on and given not in on:
            c.err(m, "bodies" if "between" in m else "body", where,
                  f"expected a body point {_printed(point)} is on ({', '.join(on)}); got {given!r}")
        return given
    if "ground" in on and ground_ok:
        return "ground"
    moving = [b for b in on if b != "ground"]
    if len(moving) == 1:
        return moving[0]
    c.err(m, "bodies" if "between" in m else "at", where,
          f"expected the body it acts on (point {_printed(point)} joins {', '.join(on) or 'no body'}): "
          f"give {'bodies: [..]' if 'between' in m else 'body:'}")
    return ""


def _printed(point: str) -> str:
    return point[len(DEFINED) :] if point.startswith(DEFINED) else point


def _motion_load(c, m, w, typ, name, names, bodies, points, labels, carried) -> LoadSpec | None:
    """A load computed from the motion: damper, spring, rotary damper or velocity-opposing resistance."""
    coeff_key = {"damper": "c", "spring": "k", "rotary_damper": "c", "resistance": "magnitude"}[typ]
    coefficient = _value(c, m, coeff_key, f"{w}.{coeff_key}", names)
    if typ == "rotary_damper":
        link = _body_named(c, m, "link", f"{w}.link", bodies, labels)
        rel = _body_named(c, m, "relative_to", f"{w}.relative_to", bodies, labels, ground=True) if (
            "relative_to" in m) else "ground"
        if "body" in m:
            c.err(m, "body", f"{w}.body", "expected link: (the body the couple acts on), got body:")
        return LoadSpec(name, link, type=typ, coefficient=coefficient, relative_to=rel)
    if typ == "resistance":
        at = _point(c, m, f"{w}.at", points)
        given = _body_named(c, m, "body", f"{w}.body", bodies, labels) if "body" in m else None
        body = _end_body(c, m, f"{w}.body", at, given, carried, ground_ok=False) if at else ""
        return LoadSpec(name, body, at, type=typ, magnitude=coefficient)
    ends = m.get("between")
    if not isinstance(ends, list) or len(ends) != 2:
        c.err(m, "between", f"{w}.between", f"expected two points [P, Q], got {_show(ends)}")
        return None
    pts = [_point(c, {"at": e}, f"{w}.between", points) for e in ends]
    given = m.get("bodies")
    if given is not None and (not isinstance(given, list) or len(given) != 2):
        c.err(m, "bodies", f"{w}.bodies", f"expected the body of each end [body of P, body of Q], got {_show(given)}")
        given = None
    gb = [None, None]
    if given is not None:
        gb = [_body_named(c, {"b": g}, "b", f"{w}.bodies", bodies, labels, ground=True) for g in given]
    ends_b = tuple(_end_body(c, m, f"{w}.bodies", p, g, carried, True) if p else "" for p, g in zip(pts, gb,
                                                                                                   strict=True))
    free = _value(c, m, "free_length", f"{w}.free_length", names, 0.0) if typ == "spring" else 0.0
    return LoadSpec(name, ends_b[1], type=typ, between=tuple(pts), bodies=ends_b, coefficient=coefficient,
                    free_length=free if free is not None else 0.0)


def _point(c: _Collector, m: dict, where: str, shown: dict[str, str], key: str = "at") -> str:
    """A point named as the sheet prints it (``mechanism.points``), as the solver's internal name.

    A point renamed for display is only known by its printed name, so ``at: A`` always means the
    point labelled A on the student's figure.
    """
    at = m.get(key, "")
    if not at:
        return ""
    internal = {printed: name for name, printed in shown.items()}
    if at in internal:
        return internal[at]
    printed = ", ".join(sorted(internal))
    if at in shown:
        c.err(
            m,
            key,
            where,
            f"expected a point as printed in this problem ({printed}); got {at!r}, which is printed as {shown[at]!r}",
        )
    else:
        c.err(m, key, where, f"expected a point among {printed}; got {_show(at)}")
    return ""


def _mass(c: _Collector, data: dict, names: set[str], bodies: set[str], points: set[str]) -> tuple[MassSpec, ...]:
    node = data.get("mass", {})
    m0 = c.mapping(node, "mass", (), tuple(sorted(bodies)), data, "mass")
    out = []
    for body, spec in (m0 or {}).items():
        w = f"mass.{body}"
        m = c.mapping(spec, w, (), ("mass", "weight", "inertia", "at", "along", "across"), m0, body)
        if m is None:
            continue
        vals = {k: _value(c, m, k, f"{w}.{k}", names) for k in ("mass", "weight", "inertia", "along", "across")}
        if (vals["mass"] is None) == (vals["weight"] is None):
            c.err(m, None, w, "expected exactly one of mass or weight")
        at = _point(c, m, f"{w}.at", points)
        out.append(
            MassSpec(
                body,
                vals["mass"],
                vals["weight"],
                vals["inertia"] or 0.0,
                str(at),
                vals["along"] or 0.0,
                vals["across"] or 0.0,
            )
        )
    return tuple(out)


def _constraints(c: _Collector, data: dict, names: set[str]) -> Constraints:
    node = data.get("constraints", {})
    m = (
        c.mapping(
            node,
            "constraints",
            (),
            (
                "transmission_min",
                "condition_max",
                "grashof",
                "dead_centre_min",
                "answer_min_fraction",
                "require",
                "gradable",
                "distinguish",
                "distinguish_factor",
                "bands",
            ),
            data,
            "constraints",
        )
        or {}
    )
    req = []
    for i, item in enumerate(m.get("require", []) or []):
        r = c.mapping(item, f"constraints.require[{i}]", ("expr", "message"), (), m.get("require"), i)
        if r is None:
            continue
        e = r.get("expr")
        try:
            unknown = expr.names(e) - names if isinstance(e, str) else {"<not text>"}
            if unknown:
                c.err(
                    r,
                    "expr",
                    f"constraints.require[{i}].expr",
                    f"expected parameter names, got unknown {sorted(unknown)}",
                )
        except expr.ExprError as exc:
            c.err(r, "expr", f"constraints.require[{i}].expr", str(exc))
        req.append((str(e), str(r.get("message", ""))))
    grashof = m.get("grashof")
    if grashof is not None and grashof not in ("crank-rocker", "double-crank", "grashof", "non-grashof"):
        c.err(
            m,
            "grashof",
            "constraints.grashof",
            f"expected crank-rocker, double-crank, grashof or non-grashof; got {_show(grashof)}",
        )
    mistakes = ("static-answer", "no-inertia-torque", "no-gravity", "x-y-swapped", "magnitude-for-component")
    keys = {a.get("key") for a in data.get("answers", []) or [] if isinstance(a, dict)}
    distinguish = []
    dnode = m.get("distinguish", {})
    for name in c.mapping(dnode, "constraints.distinguish", (), mistakes, m, "distinguish") or {}:
        ks = dnode[name]
        if not isinstance(ks, list) or not all(k in keys for k in ks):
            c.err(
                dnode,
                name,
                f"constraints.distinguish.{name}",
                f"expected a list of answer keys among {', '.join(sorted(map(str, keys)))}; got {_show(ks)}",
            )
            continue
        distinguish.append((name, tuple(ks)))
    bands = {}
    bnode = m.get("bands", {})
    for k in c.mapping(bnode, "constraints.bands", (), tuple(sorted(map(str, keys))), m, "bands") or {}:
        w = f"constraints.bands.{k}"
        angle = isinstance(bnode[k], dict) and "deg" in bnode[k]
        b = c.mapping(bnode[k], w, (), ("deg",) if angle else ("rel", "abs", "floor"), bnode, k)
        if b is not None and "deg" in b:
            bands[k] = Tolerance("relative", 0.0, c.number(b, "deg", f"{w}.deg", positive=True) or 0.0, period=360.0)
        elif b is not None:
            r, ab, fl = (c.number(b, f, f"{w}.{f}", 0.0) or 0.0 for f in ("rel", "abs", "floor"))
            if not (0 <= r < 1 and ab >= 0 and 0 <= fl < 1 and r + ab + fl > 0):
                c.err(bnode, k, w, f"expected rel and floor from 0 to 1 and abs ≥ 0, not all 0; got {_show(b)}")
            bands[k] = Tolerance("relative", r, ab, floor=fl)
    return Constraints(
        c.number(m, "transmission_min", "constraints.transmission_min", 0.0) or 0.0,
        c.number(m, "condition_max", "constraints.condition_max", 1e4, positive=True) or 1e4,
        grashof,
        c.number(m, "dead_centre_min", "constraints.dead_centre_min", 0.0) or 0.0,
        c.number(m, "answer_min_fraction", "constraints.answer_min_fraction", 0.0) or 0.0,
        tuple(req),
        c.number(m, "gradable", "constraints.gradable", GRADABLE) or 0.0,
        tuple(distinguish),
        c.number(m, "distinguish_factor", "constraints.distinguish_factor", 2.0, positive=True) or 2.0,
        bands,
    )


def _cases(c: _Collector, data: dict, names: set[str]) -> dict[str, dict[str, Value]]:
    node = data.get("cases")
    if node is None:
        return {}
    if not isinstance(node, dict) or not node:
        c.err(data, "cases", "cases", f"expected a mapping of case name: parameter overrides, got {_show(node)}")
        return {}
    out = {}
    for name, over in node.items():
        if not isinstance(over, dict):
            c.err(node, name, f"cases.{name}", f"expected a mapping of parameter: value, got {_show(over)}")
            continue
        vals = {}
        for k in over:
            if k not in names:
                c.err(over, k, f"cases.{name}.{k}", f"expected a parameter name, got {k!r}")
            v = _value(c, over, k, f"cases.{name}.{k}", names)  # a number, or an expression of the parameters
            if isinstance(v, str) and k in expr.names(v):
                c.err(over, k, f"cases.{name}.{k}", f"expected an expression of the other parameters (the "
                      f"override replaces {k}), got {v!r}")
            if v is not None:
                vals[k] = v
        out[str(name)] = vals
    return out


def _answers(c: _Collector, data: dict, method: str, cases: dict) -> tuple[AnswerSpec, ...]:
    node = data.get("answers")
    if not isinstance(node, list) or not node:
        c.err(data, "answers", "answers", f"expected a list of answers, got {_show(node)}")
        return ()
    out = []
    keys: set[str] = set()
    for i, item in enumerate(node):
        w = f"answers[{i}]"
        optional = ("sign", "points", "tolerance", "case", "hand_check")
        m = c.mapping(item, w, ("key", "of", "unit", "description"), optional, node, i)
        if m is None:
            continue
        key = m.get("key")
        if not isinstance(key, str) or not re.match(r"^[A-Za-z][A-Za-z0-9_]*$", key):
            c.err(m, "key", f"{w}.key", f"expected a name of letters, digits and _, got {_show(key)}")
            key = f"answer{i}"
        if key in keys:
            c.err(m, "key", f"{w}.key", f"expected a unique key, got {key!r} twice")
        keys.add(key)
        of = m.get("of")
        if isinstance(of, str) and of.startswith("param[") and of[6:-1] not in data.get("parameters", {}):
            c.err(m, "of", f"{w}.of", f"expected param[<a parameter name>], got {of!r}")
        problem_text = None
        if isinstance(of, str) and quantities.parse(of) is None:
            try:
                d = quantities.derived(of)
                if d is not None:
                    unknown = expr.names(d.text) - set(d.refs) - set(data.get("parameters", {}) or {})
                    if unknown:
                        problem_text = f"expected results and parameter names, got unknown {', '.join(sorted(unknown))}"
            except (ValueError, expr.ExprError) as exc:
                d, problem_text = None, str(exc)
            if problem_text is None and d is None:
                problem_text = "expected a result"
            if problem_text:
                c.err(
                    m,
                    "of",
                    f"{w}.of",
                    f"{problem_text}: a result such as driver, F[3,2].mag, aG[2].angle, h[3], driver@P, or an "
                    f"expression of results and parameters such as -driver or along(F[2,3], 3) "
                    f"(the quantities: {quantities.grammar()}); got {_show(of)}",
                )
        elif not isinstance(of, str):
            c.err(m, "of", f"{w}.of", f"expected a result such as driver or F[3,2].mag, got {_show(of)}")
        unit = c.unit(m, "unit", f"{w}.unit")
        case = m.get("case")
        if case is not None and str(case) not in cases:
            c.err(
                m,
                "case",
                f"{w}.case",
                f"expected one of the cases {', '.join(cases) or '(none defined)'}; got {_show(case)}",
            )
        pts = c.number(m, "points", f"{w}.points", 1.0)
        if pts is not None and pts < 0:
            c.err(m, "points", f"{w}.points", f"expected a number of at least 0, got {pts}")
        try:
            base = tolerances.default(method, str(of), unit) if unit else Tolerance()
        except GradekitError:  # the unreadable unit is reported by c.unit above
            base = Tolerance()
        tol = _tolerance(c, m.get("tolerance"), f"{w}.tolerance", base, m)
        hand = m.get("hand_check", False)
        if not isinstance(hand, bool):
            c.err(m, "hand_check", f"{w}.hand_check", f"expected true or false, got {_show(hand)}")
            hand = False
        out.append(
            AnswerSpec(
                key,
                str(of),
                unit,
                c.text(m, "description", f"{w}.description", ""),
                str(m.get("sign", "")),
                pts or 0.0,
                tol,
                None if case is None else str(case),
                "tolerance" in m,
                hand,
            )
        )
    return tuple(out)


def _check_asked(c: _Collector, data: dict, answers: tuple[AnswerSpec, ...], labels: dict[str, str],
                 shown: dict[str, str], load_names: set[str], names: set[str], kind: str) -> None:
    """What every answer's ``of:`` refers to exists in this problem: links, joints, points, groups,
    and its unit has the dimension of the result (so nothing fails later, at solve time)."""
    from gradekit.mechanics.mechanisms import joint_pairs

    spec = KINDS[kind]
    body_of = {labels.get(b, b): b for b in ("ground", *spec.bodies)}
    moving = {lab for lab, b in body_of.items() if b != "ground"}
    pairs = joint_pairs(kind)
    groups = {*load_names, "gravity", *(f"inertia[{lab}]" for lab in moving)}
    printed = set(shown.values())
    node = data.get("answers") or []
    for i, (a, m) in enumerate(zip(answers, node, strict=False)):
        w = f"answers[{i}].of"
        try:
            plain = quantities.parse(a.of)
            d = None if plain else quantities.derived(a.of)
        except ValueError:
            continue  # reported by _answers
        refs = [("", plain, "")] if plain else list(d.refs.values()) if d else []
        for proj, asked, link in refs:
            q, args, problems = asked.quantity, asked.args, []
            if q.brackets == "k" and args not in moving:
                problems.append(f"a moving link's label ({', '.join(sorted(moving))}), got [{args}]")
            elif q.brackets == "i,j":
                i_, j_ = (x.strip() for x in args.split(",", 1))
                if i_ not in body_of or j_ not in body_of:
                    problems.append(f"two link labels among {', '.join(sorted(body_of))}, got [{args}]")
                elif (body_of[i_], body_of[j_]) not in pairs:
                    joined = sorted({f"{labels.get(x, x)},{labels.get(y, y)}" for x, y in pairs})
                    problems.append(f"two links joined by a joint ({'; '.join(joined)}), got [{args}]")
            elif q.brackets == "P" and args not in printed:
                problems.append(f"a point as printed ({', '.join(sorted(printed))}), got [{args}]")
            if asked.group and asked.group not in groups:
                problems.append(f"a superposition group among {', '.join(sorted(groups))}, got @{asked.group}")
            if proj and link not in moving:
                problems.append(f"a moving link's label in {proj}(…, k), got {link!r}")
            for p_ in problems:
                c.err(m, "of", w, f"expected {p_}")
        if plain and plain.quantity.name not in ("param", "driver") and a.unit:
            try:
                same = units.si_unit(a.unit) == units.si_unit(plain.si)
            except GradekitError:
                continue  # an unreadable unit is reported by _answers
            if not same:
                c.err(m, "unit", f"answers[{i}].unit", f"expected a unit of the same kind as {plain.si} for "
                      f"{a.of}, got {a.unit!r}")


def _answer_keys(answers: tuple[AnswerSpec, ...], cases: dict) -> set[str]:
    """The keys answers are known by: ``T``, or ``T_a``, ``T_b`` for an answer asked in every case."""
    out: set[str] = set()
    for a in answers:
        if a.case is not None or not cases:
            out.add(a.key)
        else:
            out.update(f"{a.key}_{k}" for k in cases)
    return out


def _published(c: _Collector, data: dict, keys: set[str], cases: dict) -> tuple[Published, ...]:
    """``published:``: ``answers`` by key (``T_a`` for case a), or a block per case
    (``cases: {a: {T: …}}``); each ``{value, unit, rel and/or abs, note}``."""
    node = data.get("published")
    if node is None:
        return ()
    m = c.mapping(node, "published", (), ("answers", "cases", "note"), data, "published") or {}
    blocks = [("published.answers", m.get("answers", {}), m, "answers", "")]
    cnode = m.get("cases")
    if cnode is not None:
        cm = c.mapping(cnode, "published.cases", (), tuple(cases), m, "cases") or {}
        blocks += [(f"published.cases.{k}", cm[k], cm, k, f"_{k}") for k in cm]
    out = []
    for where, ans, parent, pkey, suffix in blocks:
        allowed = sorted(keys) if not suffix else sorted(k[: -len(suffix)] for k in keys if k.endswith(suffix))
        am = c.mapping(ans, where, (), tuple(allowed), parent, pkey) or {}
        for k, spec in am.items():
            w = f"{where}.{k}"
            s = c.mapping(spec, w, ("value", "unit"), ("rel", "abs", "note"), am, k)
            if s is None:
                continue
            v = c.number(s, "value", f"{w}.value")
            unit = c.unit(s, "unit", f"{w}.unit")
            rel = c.number(s, "rel", f"{w}.rel", 0.0) or 0.0
            ab = c.number(s, "abs", f"{w}.abs", 0.0) or 0.0
            if rel < 0 or ab < 0 or rel + ab <= 0:
                c.err(s, "rel", w, f"expected the printed precision: rel > 0 or abs > 0 (both ≥ 0); got rel {rel}, "
                      f"abs {ab}")
            out.append(Published(k + suffix, v or 0.0, unit, rel, str(s.get("note", "")), ab))
    return tuple(out)


def _figure(c: _Collector, data: dict) -> Figure:
    node = data.get("figure")
    if node is None:
        return Figure()
    m = c.mapping(node, "figure", (), ("show", "true_scale", "force_scale"), data, "figure") or {}
    show = m.get("show", list(Figure.show))
    if not isinstance(show, list) or not all(s in SHOW for s in show):
        c.err(m, "show", "figure.show", f"expected a list among {', '.join(sorted(SHOW))}; got {_show(show)}")
        show = list(Figure.show)
    scale = c.number(m, "true_scale", "figure.true_scale", positive=True)
    return Figure(tuple(show), scale, str(m.get("force_scale", "")))


def load_problem(path: Path | str) -> Problem:
    """Load and validate one problem file, with the measured tolerance defaults of its folder."""
    from gradekit.bank.yamlfile import load

    problem = validate(load(path), str(path))
    return apply_measured(problem, measured_tolerances(Path(path).resolve().parent))


