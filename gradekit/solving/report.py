"""What `gradekit solve` and `bank show` report: parameters, intermediate values, answers, checks."""

from __future__ import annotations

from gradekit import units
from gradekit.numbers import fmt
from gradekit.solving.pipeline import Result

# SI unit of a flat result -> the problem's display dimension
_DISPLAY = {
    "N": "force",
    "N*m": "torque",
    "m": "length",
    "deg": None,
    "rad/s": None,
    "rad/s**2": None,
    "m/s**2": "accel",
    "m/s": "speed",
}


def display_unit(problem, si_unit: str) -> str:
    dim = _DISPLAY.get(si_unit)
    if dim is None:
        return si_unit
    if dim == "accel":
        return f"{problem.units['length']}/s**2"
    if dim == "speed":
        return f"{problem.units['length']}/s"
    return problem.units[dim]


def intermediate(result: Result) -> dict:
    """Selected intermediate values per case, in the problem's display units."""
    p = result.problem
    out = {}
    dynamic = p.analysis == "dynamic"
    for case in result.cases:
        res = case.results
        sel = {}
        for key, (v, u) in res.items():
            base = key.split(".")[0]
            if "@" in key and not key.startswith(("driver@",)) and not key.endswith(".mag"):
                continue
            if key.startswith(("v[", "a[", "vG[")):
                continue
            if key.startswith(("aG[", "alpha[", "omega[", "Fi[", "Ci[", "h[")) and not dynamic:
                continue
            if key.startswith(("F[", "aG[", "Fi[")) and not (
                key.endswith((".mag", ".angle")) or key.endswith((".x", ".y"))
            ):
                continue
            if key.startswith("F[") and _reverse_seen(base, sel):
                continue
            du = display_unit(p, u)
            sel[key] = {"value": units.convert(v, u, du) if du != u else v, "unit": du}
        _drop_repeats(sel)
        if dynamic:
            for body, st in case.solution.states.items():
                if st.inertia_couple and st.mass:
                    sel[f"h_side[{p.label(body)}]"] = {"value": offset_side(st.inertia_couple), "unit": ""}
        out[case.name or "_"] = sel
    return out


def _drop_repeats(sel: dict) -> None:
    """Remove what another line already says: a vector's bare name (its magnitude, as ``.mag``) and a
    force's magnitude at a point (``F[1,2]@B.mag``, the same as ``F[1,2].mag``)."""
    for key in list(sel):
        base = key.split("@", 1)[0].removesuffix(".mag") if key.endswith(".mag") and "@" in key else key
        same = sel.get(f"{base}.mag")
        if key != f"{base}.mag" and same is not None and same["value"] == sel[key]["value"] \
                and same["unit"] == sel[key]["unit"]:
            del sel[key]


def shown_value(value: float, scale: float) -> float:
    """*value* as printed: 0 when it is below *scale* × 1e-12 (round-off of a zero, e.g. 5.3e-15 N
    where the forces are tens of newtons)."""
    return 0.0 if abs(value) < abs(scale) * 1e-12 else value


def offset_side(couple: float) -> str:
    """Where the equivalent offset inertia force passes G so that its moment equals the inertia couple."""
    side = "right" if couple > 0 else "left"
    return f"{side} of G, looking along the inertia force (its moment about G is {'CCW' if couple > 0 else 'CW'})"


def graphical(result: Result) -> dict:
    """The graphical method as data, per case and body: member kind, forces with their lines of action
    (a point and the vector), the concurrency point of a three-force member and the force-polygon
    vertices, in the problem's display units."""
    p = result.problem
    k_len = units.factor("m", p.units["length"])
    k_f = units.factor("N", p.units["force"])
    k_t = units.factor("N*m", p.units["torque"])
    out = {}
    for case in result.cases:
        members = {}
        for body, m in case.solution.total.members.items():
            members[p.label(body)] = {
                "kind": m.kind,
                "forces": [
                    {
                        "name": f.name,
                        "kind": f.kind,
                        "point": [float(x) * k_len for x in f.point],
                        "vector": [float(x) * k_f for x in f.vector],
                    }
                    for f in m.forces
                ],
                "couples": [{"name": n, "value": c * k_t} for n, c in m.couples],
                "concurrency": None if m.concurrency is None else [float(x) * k_len for x in m.concurrency],
                "polygon": [[float(x) * k_f for x in row] for row in m.polygon],
            }
        out[case.name or "_"] = {
            "units": {"length": p.units["length"], "force": p.units["force"], "torque": p.units["torque"]},
            "members": members,
        }
    return out


def _reverse_seen(base: str, sel: dict) -> bool:
    inside = base[2:].split("]")[0]
    a, b = inside.split(",")
    rest = base.split("]", 1)[1]
    rev = f"F[{b},{a}]{rest}"
    return any(k.startswith(rev + ".") for k in sel)


def as_json(result: Result) -> dict:
    p = result.problem
    return {
        "problem": p.id,
        "title": p.title,
        "source": p.source,
        "parameters": {n: {"value": v, "unit": p.parameters[n].unit} for n, v in result.values.items()},
        "answers": {
            a.key: {
                "value": a.value,
                "unit": a.unit,
                "description": a.description,
                "sign": a.sign,
                "points": a.points,
                "tolerance": a.tolerance.describe(),
            }
            for a in result.answers
        },
        "intermediate": intermediate(result),
        "graphical": graphical(result),
        "checks": {
            "virtual_work_residual": result.virtual_work_residual,
            "condition_number": result.condition_number,
            "transmission_angle": result.transmission_angle,
        },
    }


def as_text(result: Result) -> str:
    p = result.problem
    lines = [
        f"{p.id}: {p.title}",
        f"  source: {p.source.get('document', '')}, {p.source.get('ref', '')}",
        "parameters:",
    ]
    for n, v in result.values.items():
        par = p.parameters[n]
        lines.append(f"  {n:<10} = {units.with_unit(fmt(v, 6), par.unit)}  {par.description}")
    for name, sel in intermediate(result).items():
        lines.append("intermediate" + ("" if name == "_" else f" (case {name})") + ":")
        scales: dict[str, float] = {}  # per unit, the largest value of the case
        for d in sel.values():
            if not isinstance(d["value"], str):
                scales[d["unit"]] = max(scales.get(d["unit"], 0.0), abs(d["value"]))
        for k, d in sel.items():
            value = d["value"]
            shown = value if isinstance(value, str) else units.with_unit(
                fmt(shown_value(value, scales[d["unit"]])), d["unit"])
            lines.append(f"  {k:<22} = {shown}")
    lines.append("answers:")
    for a in result.answers:
        sign = f"  [{a.sign}]" if a.sign else ""
        value = shown_value(a.value, a.scale or abs(a.value))
        lines.append(f"  {a.key:<8} = {units.with_unit(fmt(value), a.unit)}  {a.description}{sign}")
    lines.append(
        f"checks: virtual-work residual {result.virtual_work_residual:.2e}, condition number "
        f"{result.condition_number:.3g}, transmission angle {result.transmission_angle:.1f}°"
    )
    return "\n".join(lines)
