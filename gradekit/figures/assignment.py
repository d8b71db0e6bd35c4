"""The assignment figure: one student's mechanism with the given values, never a solved answer."""

from __future__ import annotations

import math

import numpy as np

from gradekit import units
from gradekit.figures.canvas import BLACK, BLUE, GREEN, GREY, PURPLE, VERMILION, Canvas
from gradekit.figures.mech import BAR, PIN, com_marker, draw_linkage, mech_extent
from gradekit.mechanics.mechanisms import KINDS
from gradekit.mechanics.model import GROUND, Prismatic
from gradekit.pipeline import CaseResult, Result
from gradekit.report import fmt

PT_PER_M = 72.0 / 0.0254  # paper points per metre
FIT = (300.0, 220.0)  # drawing box of a figure not to scale, in points
ARROW = (24.0, 52.0)  # shortest and longest force arrow, in points
CRANK_ROOM, GROW = 70.0, 4 / 3  # a scene whose crank is drawn shorter is drawn up to GROW × larger



def show_value(problem, values: dict[str, float], name: str) -> str:
    """'30 mm', '45°', '95 rad/s': a parameter's value in its own unit."""
    p = problem.parameters[name]
    u = units.pretty(p.unit)
    return f"{fmt(values[name])}{'' if u == '°' else ' '}{u}"


def given(problem, values: dict[str, float], name: str, default: str) -> str:
    p = problem.parameters.get(name)
    sym = (p.symbol if p and p.symbol else default) if p else default
    return f"{sym} = {show_value(problem, values, name)}"


def force_text(problem, newtons: float) -> str:
    unit = problem.units["force"]
    return f"{fmt(units.convert(abs(newtons), 'N', unit), 4)} {units.pretty(unit)}"


def torque_text(problem, nm: float) -> str:
    unit = problem.units["torque"]
    return f"{fmt(units.convert(abs(nm), 'N*m', unit), 4)} {units.pretty(unit)}"


def arrow_len(mag: float, biggest: float) -> float:
    """Arrow length in points: proportional to the force, kept within ARROW."""
    lo, hi = ARROW
    return lo + (hi - lo) * (mag / biggest if biggest > 0 else 1.0)


def nice(x: float) -> float:
    """The largest 1, 2 or 5 × 10^k not above *x*."""
    if x <= 0:
        return 1.0
    e = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10**e <= x:
            return m * 10**e
    return 10**e


def ratio_text(k: float) -> str:
    """1 -> '1:1', 0.25 -> '1:4', 2 -> '2:1', 0.75 -> '3:4' (never '1:1.333')."""
    from fractions import Fraction

    f = Fraction(k).limit_denominator(20)
    if f > 0 and abs(float(f) - k) <= 1e-9 * k:
        return f"{f.numerator}:{f.denominator}"
    if k >= 1:
        return f"{fmt(k, 4)}:1"
    return f"1:{fmt(1 / k, 4)}"


def load_point_name(problem, spec) -> str:
    """The name of a load's point of application when its dimension names it: ``O4C`` from O4 -> C."""
    if not (spec.at and isinstance(spec.along, str) and spec.along in problem.parameters):
        return ""
    sym = problem.parameters[spec.along].symbol or ""
    start = problem.point(spec.at)
    rest = sym[len(start):] if sym.startswith(start) else ""
    return rest if 1 <= len(rest) <= 2 and rest[:1].isalpha() else ""


def com_name(problem, body: str) -> str:
    """A body's centre of mass as the statement names it: G from ``BG``, g2 from ``O2g2``, else G<link>;
    a mass placed at a point without offset (a slider's at C) is that point."""
    spec = next((m for m in problem.mass if m.body == body), None)
    if spec is not None:
        name = load_point_name(problem, spec)
        if name:
            return name
        if body in ("slider", "ram", "piston", "block") and spec.at and not spec.along and not spec.across:
            return problem.point(spec.at)
    return f"G{problem.label(body)}"


def pick_case(result: Result, case: str | None) -> CaseResult:
    if case is None:
        return result.cases[0]
    for c in result.cases:
        if c.name == case:
            return c
    raise KeyError(f"expected a case among {[c.name for c in result.cases]}, got {case!r}")


GREEK = {"tau": "τ", "alpha": "α", "omega": "ω", "theta": "θ", "phi": "φ"}


def driver_key(result: Result) -> str:
    """The name the problem gives the driving torque or force (its answer key, ``tau`` printed as
    the statement's τ), else T."""
    for a in result.problem.answers:
        if a.of == "driver":
            return GREEK.get(a.key, a.key)
    return "T"


# Paper a true-scale drawing may use, in points (A4, the documents' 2 cm margins, less the SVG
# margin and room for the caption): portrait, or a landscape page of its own.
PORTRAIT = ((210 - 40) / 25.4 * 72 - 12.0, (297 - 42) / 25.4 * 72 - 70.0)
LANDSCAPE = ((297 - 40) / 25.4 * 72 - 12.0, (210 - 42) / 25.4 * 72 - 70.0)
PRINTABLE = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)  # 1:1, 1:2, 1:5, 1:10, ...
_SCALES: dict[tuple, float] = {}


def printed_scale(result: Result, case: str | None = None) -> float | None:
    """The scale a true-scale scene is printed at (paper length per mechanism length).

    The problem's ``figure.true_scale`` when the drawing fits a portrait or a landscape page, else
    the largest printable scale (1:2, 1:5, 1:10, ...) below it that fits. None without one.
    """
    k0 = result.problem.figure.true_scale
    if not k0:
        return None
    k = _SCALES.get(_scale_key(result, case))
    return k if k is not None else _fit_scale(result, case, k0)[0]


def _scale_key(result: Result, case: str | None) -> tuple:
    return (result.problem.id, result.problem.path, tuple(sorted(result.values.items())), case)


def _fits(w: float, h: float) -> bool:
    return any(w <= W and h <= H for W, H in (PORTRAIT, LANDSCAPE))


def _fit_scale(result: Result, case: str | None, k0: float) -> tuple[float, Canvas]:
    for k in (k0, *(r for r in PRINTABLE if r < k0 - 1e-12)):
        cv = _build(result, case, k)
        x0, y0, x1, y1 = cv.extent()
        if _fits(x1 - x0, y1 - y0):
            break
    if len(_SCALES) > 512:
        _SCALES.clear()
    _SCALES[_scale_key(result, case)] = k
    return k, cv


def build_scene(result: Result, case: str | None = None, true_scale: bool = False) -> Canvas:
    """The assignment scene of one case on a canvas (see `gradekit.figures.scene`).

    A true-scale scene is drawn at `printed_scale`, with the scale bar and the scale printed.
    """
    k0 = result.problem.figure.true_scale
    if true_scale and k0:
        return _fit_scale(result, case, k0)[1]
    return _build(result, case, None)


def _build(result: Result, case: str | None, k_paper: float | None) -> Canvas:
    pr = result.problem
    cr = pick_case(result, case)
    values = cr.values
    sol = cr.solution
    link = sol.linkage
    show = set(pr.figure.show)
    lo, hi = mech_extent(link, [st.g for st in sol.states.values()])
    span = np.maximum(hi - lo, 1e-6)
    true_scale = bool(k_paper)
    s = PT_PER_M * k_paper if k_paper else min(FIT[0] / span[0], FIT[1] / span[1], 6 * PT_PER_M)
    if not k_paper and "O2" in link.points and "A" in link.points:
        # a crank short beside the rest leaves no room for the labels around it: draw larger
        crank = float(np.hypot(*(link.points["A"].pos() - link.points["O2"].pos()))) * s
        if 0 < crank < CRANK_ROOM:
            s *= min(GROW, CRANK_ROOM / crank)
    centre = (lo + hi) / 2

    def T(p):
        return (np.asarray(p, float) - centre) * s

    cv = Canvas()
    P = draw_linkage(cv, link, T)
    mid = T(centre)
    members = sol.total.members

    # loads (given forces and torques)
    loads = [f for m in members.values() for f in m.forces if f.kind == "load"]
    specs = {ld.name: ld for ld in pr.loads}
    biggest = max((float(np.hypot(*f.vector)) for f in loads), default=0.0)
    arrows = []
    if "loads" in show:
        for f in loads:
            mag = float(np.hypot(*f.vector))
            u = f.vector / mag
            head = T(f.point)
            # push arrows end at the point from outside; back off from a pin
            head = head - u * (PIN + 1.0)
            tail = head - u * arrow_len(mag, biggest)
            cv.arrow(tail, head, VERMILION, 1.5, gid=f"load-{f.name}")
            arrows.append((f, tail, head))
        for name, tq in [(c, v) for m in members.values() for c, v in m.couples if c != "driver"]:
            body = next(b for b, m in members.items() if (name, tq) in m.couples)
            c = T(link.bodies[body].origin.pos())
            torque_arc(cv, c, 20.0, tq, VERMILION, f"torque-{name}")
            sp = specs.get(name)
            txt = f"{name} = {show_value(pr, values, sp.torque)}" if sp and isinstance(sp.torque, str) \
                and sp.torque in pr.parameters else f"{name} = {torque_text(pr, tq)}"
            cv.label(txt, arc_anchors(c, 20.0), VERMILION, clear=3.0)
    # the unknown driving torque / force: drawn positive (CCW / along the axis), named, no value
    if "torque" in show:
        drv = link.driver
        key = driver_key(result)
        if drv.kind == "torque":
            c = T(link.bodies[drv.body].origin.pos())
            torque_arc(cv, c, 15.0, 1.0, BLUE, "driver")
            cv.label(f"{key} (ccw +)", arc_anchors(c, 15.0), BLUE, clear=3.0)
        else:
            j = next(j for j in link.joints if j.name == drv.joint)
            u = np.array([math.cos(float(j.axis.v)), math.sin(float(j.axis.v))])
            c = T(j.point.pos())
            tail = c + u * 16.0
            cv.arrow(tail, tail + u * 26.0, BLUE, 1.4, gid="driver")
            cv.label(key, tail + u * 26.0, BLUE, clear=3.0)

    # crank angle and other given angles
    th = float(link.bodies[link.input_body].angle.v)
    o2 = P.get("O2")
    if "angles" in show and o2 is not None:
        r_ang = max(22.0, min(36.0, 0.45 * float(np.hypot(*(P["A"] - o2)))))
        cv.line([o2, o2 + np.array([r_ang + 10.0, 0.0])], GREY, 0.7, "--", z=1.5)
        t = th % (2 * math.pi)
        cv.arc(o2, r_ang, 0.0, t, GREEN, 0.9, gid="angle-theta")
        name = pr.inputs.get("theta")
        txt = (given(pr, values, name, "θ") if isinstance(name, str) and name in pr.parameters
               else f"θ = {fmt(math.degrees(t))}°")
        am = [o2 + r_ang * np.array([math.cos(t * q), math.sin(t * q)]) for q in (0.5, 0.35, 0.65, 0.2, 0.8)]
        cv.label(txt, am, GREEN, clear=2.0, prefer=np.array([math.cos(t / 2), math.sin(t / 2)]))

    # speeds and accelerations given on the input link
    if show & {"velocities", "accelerations"} and o2 is not None:
        for key, r, sym in (("omega", 30.0, "ω"), ("alpha", 40.0, "α")):
            name = pr.inputs.get(key)
            sign = 1.0
            if isinstance(name, str) and name.startswith("-") and name[1:].strip() in pr.parameters:
                name, sign = name[1:].strip(), -1.0  # "-w2": the speed w2, clockwise
            if not (isinstance(name, str) and name in pr.parameters):
                continue
            v = sign * values[name]
            a0 = th + 0.6
            torque_arc(cv, o2, r, v if v else 1.0, PURPLE, f"given-{key}", start=a0, sweep=1.3)
            tip = [o2 + r * np.array([math.cos(a0 + q), math.sin(a0 + q)]) for q in (0.65, 0.3, 1.0)]
            cv.label(given(pr, values, name, sym), tip, PURPLE, clear=3.0,
                     prefer=np.array([math.cos(a0 + 0.65), math.sin(a0 + 0.65)]))

    # centres of mass
    if "com" in show:
        for body, st in sol.states.items():
            if st.mass or st.inertia:
                g = T(st.g)
                com_marker(cv, g, f"com-{body}")
    # point labels
    if "labels" in show:
        for name, p in P.items():
            cv.label(pr.point(name), p, BLACK, clear=PIN + BAR / 2 + 1.0, prefer=p - mid, gid=f"point-{name}")
        # a load point the statement names through its dimension (O4C = 4 in: the point C)
        for f, _tail, _head in arrows:
            sp = specs.get(f.name)
            name = load_point_name(pr, sp) if sp is not None else ""
            if name and name not in {pr.point(n) for n in P}:
                pt = T(f.point)
                cv.circle(pt, 1.6, BLACK, BLACK, 0.5)
                cv.label(name, pt, BLACK, clear=4.0, prefer=pt - mid, gid=f"point-load-{f.name}")
    if "com" in show:
        for body, st in sol.states.items():
            if st.mass or st.inertia:
                name = com_name(pr, body)
                if name not in {pr.point(n) for n in P}:  # a slider's mass at C is labelled C already
                    cv.label(name, T(st.g), BLACK, clear=5.0, prefer=T(st.g) - mid)
    # dimension labels of given lengths
    if "dimensions" in show:
        dims = KINDS[pr.kind].dimensions
        for gname, value in pr.geometry.items():
            if not (isinstance(value, str) and value in pr.parameters) or gname not in dims:
                continue
            a, b = dims[gname]
            if a not in P or b not in P:
                continue
            pa, pb = P[a], P[b]
            d = pb - pa
            n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
            if float(np.dot(n, (pa + pb) / 2 - mid)) < 0:
                n = -n
            anchors = [pa + d * f for f in (0.5, 0.38, 0.62, 0.26, 0.74)]
            cv.label(given(pr, values, value, gname), anchors, BLACK, clear=BAR / 2 + 2.0, prefer=n)
        for gname in ("offset", "ram_offset"):
            value = pr.geometry.get(gname)
            if isinstance(value, str) and value in pr.parameters:
                j = next((j for j in link.joints if isinstance(j, Prismatic) and j.guide == GROUND), None)
                if j is not None:
                    cv.label(given(pr, values, value, "e"), T(j.point.pos()), BLACK, clear=16.0,
                             prefer=np.array([0.0, -1.0]))
        for ld in pr.loads:
            if isinstance(ld.along, str) and ld.along in pr.parameters:
                f = next((f for f, _, _ in arrows if f.name == ld.name), None)
                if f is not None:
                    start = T(link.points[ld.at].pos() if ld.at else link.bodies[ld.body].origin.pos())
                    anchors = [start + (T(f.point) - start) * q for q in (0.5, 0.35, 0.65)]
                    cv.label(given(pr, values, ld.along, ld.along), anchors, BLACK, clear=BAR / 2 + 2.0)
        for m in pr.mass:
            if isinstance(m.along, str) and m.along in pr.parameters and "com" in show:
                st = sol.states[m.body]
                start = T(link.points[m.at].pos() if m.at else link.bodies[m.body].origin.pos())
                anchors = [start + (T(st.g) - start) * q for q in (0.5, 0.35, 0.65)]
                cv.label(given(pr, values, m.along, m.along), anchors, BLACK, clear=BAR / 2 + 2.0)
    # load labels last: they may move furthest
    for f, tail, head in arrows:
        sp = specs.get(f.name)
        txt = f"{f.name} = {force_text(pr, float(np.hypot(*f.vector)))}"
        if sp is not None and isinstance(sp.magnitude, str) and sp.magnitude in pr.parameters:
            txt = f"{f.name} = {show_value(pr, values, sp.magnitude)}"
            if isinstance(sp.angle, str) and sp.angle in pr.parameters and not sp.relative_angle:
                txt += f" at {show_value(pr, values, sp.angle)}"
        cv.label(txt, [tail + (head - tail) * q for q in (0.0, 0.5, 0.25, 0.75)], VERMILION, clear=3.0,
                 prefer=tail - head)

    if true_scale and k_paper:
        scale_note(cv, pr, k_paper, s, biggest)
    return cv


def arc_anchors(c: np.ndarray, r: float) -> list[np.ndarray]:
    """Points of a `torque_arc` (over the top) a label may stand next to: the top first."""
    return [c + r * np.array([math.cos(math.radians(a)), math.sin(math.radians(a))])
            for a in (90.0, 50.0, 130.0, 10.0, 170.0, 210.0, -30.0)]


def torque_arc(cv: Canvas, c: np.ndarray, r: float, sign: float, colour: str, gid: str,
               start: float = math.radians(-50.0), sweep: float = 4.5) -> None:
    """An arc arrow around *c* (over the top by default): counterclockwise when *sign* > 0."""
    a0, a1 = (start, start + sweep) if sign > 0 else (start + sweep, start)
    cv.arc(c, r, a0, a1, colour, 1.2, gid=gid)


def scale_note(cv: Canvas, pr, k: float, s: float, biggest: float) -> None:
    """Scale bar and the printed scale under the drawing of a true-scale figure."""
    x0, y0, x1, _ = cv.extent()
    unit = pr.units["length"]
    per_m = units.factor("m", unit)
    # a scale bar of a round mechanism length about 1/4 of the drawing
    mech_len = nice((x1 - x0) / s * per_m / 4)
    u = units.pretty(unit)
    y = cv.scale_bar(mech_len / per_m * s, f"{fmt(mech_len)} {u}", 14.0, gid="scalebar")
    paper = fmt(mech_len * k)
    lines = [f"Scale {ratio_text(k)} — {paper} {u} on paper = {fmt(mech_len)} {u}"]
    if pr.figure.force_scale:
        lines.append(f"Suggested force scale: {pr.figure.force_scale}")
    elif biggest > 0:
        fu = pr.units["force"]
        big = units.convert(biggest, "N", fu)
        # about 60 mm (2.5 in) of paper for the largest given force
        paper_len, pu = (10.0, "mm") if unit in ("mm", "m", "cm") else (0.25, "in")
        per = nice(big / (60.0 if pu == "mm" else 2.5) * paper_len)
        lines.append(f"Suggested force scale: {fmt(paper_len)} {pu} = {fmt(per)} {units.pretty(fu)}")
    for i, t in enumerate(lines):
        cv.text((x0, y - 14.0 - 11.0 * i), t, ha="left", gid="scale-note" if i == 0 else None)
