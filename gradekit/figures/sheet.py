"""The sheet's figure: one student's mechanism with the given values, never a solved answer."""

from __future__ import annotations

import math

import numpy as np

from gradekit import units
from gradekit.figures.canvas import BLACK, BLUE, GREEN, GREY, PURPLE, VERMILION, Canvas
from gradekit.figures.mech import BAR, PIN, com_marker, draw_linkage, mech_extent
from gradekit.mechanics.mechanisms import KINDS
from gradekit.mechanics.model import GROUND, Prismatic
from gradekit.numbers import fmt
from gradekit.solving.pipeline import CaseResult, Result

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


SIG = 5  # significant figures of a value a figure prints: those of the documents' tables


def force_text(problem, newtons: float) -> str:
    unit = problem.units["force"]
    return f"{fmt(units.convert(abs(newtons), 'N', unit), SIG)} {units.pretty(unit)}"


def torque_text(problem, nm: float) -> str:
    unit = problem.units["torque"]
    return f"{fmt(units.convert(abs(nm), 'N*m', unit), SIG)} {units.pretty(unit)}"


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


def heading(vec) -> str:
    """A direction in words for a text alternative: 'down and to the left, 225° from +x'."""
    x, y = float(vec[0]), float(vec[1])
    deg = math.degrees(math.atan2(y, x)) % 360.0
    tol = 1e-6 * math.hypot(x, y)
    horiz = "to the right" if x > tol else "to the left" if x < -tol else ""
    vert = "up" if y > tol else "down" if y < -tol else ""
    words = " and ".join(w for w in (vert, horiz) if w) or "nowhere"
    return f"{words}, {round(deg) % 360}° counterclockwise from +x"


def sense(value: float) -> str:
    return "counterclockwise" if value > 0 else "clockwise"


def kind_words(kind: str) -> str:
    """A mechanism kind as a reader hears it: ``slider_crank`` -> 'slider crank mechanism'."""
    return kind.replace("_", " ") + " mechanism"


def _point_list(names: list[str]) -> str:
    if len(names) <= 1:
        return "".join(names)
    return ", ".join(names[:-1]) + " and " + names[-1]


# Paper a true-scale drawing may use, in points (A4, the documents' 2 cm margins, less the SVG
# margin and room for the caption): portrait, leaving a third of the page for the problem's heading,
# statement and answer table so that they print on the figure's page, or a landscape page of its own.
PORTRAIT = ((210 - 40) / 25.4 * 72 - 12.0, (297 - 42) / 25.4 * 72 - 250.0)
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


def _fits(w: float, h: float, page: tuple[float, float]) -> bool:
    return w <= page[0] and h <= page[1]


def _fit_scale(result: Result, case: str | None, k0: float) -> tuple[float, Canvas]:
    """The scale to print at and the drawing: the problem's scale on the portrait page, so that the
    drawing prints with its problem; else one printable scale smaller on the portrait page; only then
    a landscape page of its own (at the problem's scale, then the next), and so on down the printable
    scales (`PRINTABLE`)."""
    scales = (k0, *(r for r in PRINTABLE if r < k0 - 1e-12))
    tries = [(PORTRAIT, 0), (PORTRAIT, 1), (LANDSCAPE, 0), (LANDSCAPE, 1)]
    tries += [(page, i) for i in range(2, len(scales)) for page in (PORTRAIT, LANDSCAPE)]
    drawn: dict[int, Canvas] = {}
    for page, i in [(page, i) for page, i in tries if i < len(scales)]:
        k = scales[i]
        cv = drawn[i] = drawn.get(i) or _build(result, case, k)
        x0, y0, x1, y1 = cv.extent()
        if _fits(x1 - x0, y1 - y0, page):
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
    _describe_linkage(cv, result, cr, k_paper)

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
            cv.describe(f"Given torque {txt} on link {pr.label(body)} at {pr.point(_origin_name(link, body))}, "
                        f"{sense(tq)}")
    # the unknown driving torque / force: drawn positive (CCW / along the axis), named, no value
    if "torque" in show:
        drv = link.driver
        key = driver_key(result)
        if drv.kind == "torque":
            c = T(link.bodies[drv.body].origin.pos())
            torque_arc(cv, c, 15.0, 1.0, BLUE, "driver")
            cv.label(f"{key} (ccw +)", arc_anchors(c, 15.0), BLUE, clear=3.0)
            cv.describe(f"The unknown driving torque {key} on link {pr.label(drv.body)} at "
                        f"{pr.point(_origin_name(link, drv.body))}, drawn counterclockwise as positive, "
                        f"labelled {key} (ccw +)")
        else:
            j = next(j for j in link.joints if j.name == drv.joint)
            u = np.array([math.cos(float(j.axis.v)), math.sin(float(j.axis.v))])
            c = T(j.point.pos())
            tail = c + u * 16.0
            cv.arrow(tail, tail + u * 26.0, BLUE, 1.4, gid="driver")
            cv.label(key, tail + u * 26.0, BLUE, clear=3.0)
            cv.describe(f"The unknown driving force {key} at {pr.point(link.point_at(j.point.pos()) or j.name)}, "
                        f"drawn along the slide, {heading(u)}, as positive")

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
        cv.describe(f"Crank angle {txt}, measured counterclockwise from the dashed +x line at {pr.point('O2')} "
                    f"to link {pr.label(link.input_body)}")

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
            word = "angular velocity" if key == "omega" else "angular acceleration"
            cv.describe(f"Given {word} of link {pr.label(link.input_body)}: {given(pr, values, name, sym)}, "
                        f"{sense(v) if v else 'sense as drawn'}")

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
                cv.describe(f"Mass centre {name} of link {pr.label(body)}, marked with a quartered circle")
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
            cv.describe(f"Length {given(pr, values, value, gname)}, from {pr.point(a)} to {pr.point(b)}")
        for gname in ("offset", "ram_offset"):
            value = pr.geometry.get(gname)
            if isinstance(value, str) and value in pr.parameters:
                j = next((j for j in link.joints if isinstance(j, Prismatic) and j.guide == GROUND), None)
                if j is not None:
                    cv.label(given(pr, values, value, "e"), T(j.point.pos()), BLACK, clear=16.0,
                             prefer=np.array([0.0, -1.0]))
                    cv.describe(f"Offset of the slide line {given(pr, values, value, 'e')}")
        for ld in pr.loads:
            if isinstance(ld.along, str) and ld.along in pr.parameters:
                f = next((f for f, _, _ in arrows if f.name == ld.name), None)
                if f is not None:
                    start = T(link.points[ld.at].pos() if ld.at else link.bodies[ld.body].origin.pos())
                    anchors = [start + (T(f.point) - start) * q for q in (0.5, 0.35, 0.65)]
                    cv.label(given(pr, values, ld.along, ld.along), anchors, BLACK, clear=BAR / 2 + 2.0)
                    cv.describe(f"Load {ld.name} acts at {given(pr, values, ld.along, ld.along)} from "
                                f"{pr.point(ld.at) if ld.at else 'the pivot of link ' + pr.label(ld.body)}")
        for m in pr.mass:
            if isinstance(m.along, str) and m.along in pr.parameters and "com" in show:
                st = sol.states[m.body]
                start = T(link.points[m.at].pos() if m.at else link.bodies[m.body].origin.pos())
                anchors = [start + (T(st.g) - start) * q for q in (0.5, 0.35, 0.65)]
                cv.label(given(pr, values, m.along, m.along), anchors, BLACK, clear=BAR / 2 + 2.0)
                cv.describe(f"The mass centre of link {pr.label(m.body)} lies at "
                            f"{given(pr, values, m.along, m.along)} from "
                            f"{pr.point(m.at) if m.at else 'the pivot of link ' + pr.label(m.body)}")
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
        at = pr.point(link.point_at(f.point)) if link.point_at(f.point) else load_point_name(pr, sp) if sp else ""
        cv.describe(f"Load {txt} on link {pr.label(f.body)}{' at ' + at if at else ''}, an arrow pointing "
                    f"{heading(f.vector)}")

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


def _origin_name(link, body: str) -> str:
    return link.point_at(link.bodies[body].origin.pos()) or body


def _describe_linkage(cv: Canvas, result: Result, cr: CaseResult, k_paper: float | None) -> None:
    """The opening sentences of a scene's text alternative: the mechanism, its fixed pivots, each
    link with the points it joins, and each slide; the labels drawn later add their own."""
    pr = result.problem
    link = cr.solution.linkage
    kind = KINDS[pr.kind]
    case = f", position {cr.name}" if len(result.cases) > 1 and cr.name else ""
    scale = f"drawn to scale {ratio_text(k_paper)}" if k_paper else "not drawn to scale"
    cv.describe(f"Kinematic diagram of a {kind_words(pr.kind)}{case}, {scale}; x to the right, y up")
    fixed = [pr.point(link.point_at(j.point.pos()) or j.name) for j in link.joints
             if not isinstance(j, Prismatic) and GROUND in (j.a, j.b)]
    if fixed:
        cv.describe(f"Fixed pivot{'s' if len(fixed) > 1 else ''} on the frame: {_point_list(fixed)}")
    for body, pairs in kind.bars.items():
        if body not in link.bodies:
            continue
        ends = list(dict.fromkeys(pr.point(x) for pair in pairs for x in pair if x in link.points))
        role = "" if pr.label(body) == body else f" ({body})"
        cv.describe(f"Link {pr.label(body)}{role} joins {_point_list(ends)}")
    for j in link.joints:
        if isinstance(j, Prismatic):
            at = pr.point(link.point_at(j.point.pos()) or j.name)
            on = "a fixed guide" if j.guide == GROUND else f"link {pr.label(j.guide)}"
            ang = round(math.degrees(float(j.axis.v))) % 180
            cv.describe(f"Block {pr.label(j.block)} at {at} slides on {on}, along a line at {ang}° from +x")


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
    cv.describe(f"Scale bar {fmt(mech_len)} {u}")
    for i, t in enumerate(lines):
        cv.text((x0, y - 14.0 - 11.0 * i), t, ha="left", gid="scale-note" if i == 0 else None)
        cv.describe(t)
