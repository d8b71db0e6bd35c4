"""The instructor's answer-key figures: free-body diagrams, force polygons, velocity and acceleration
polygons and the input torque over a crank cycle."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gradekit import units
from gradekit.figures.canvas import (
    BLACK,
    BLUE,
    FONT,
    GREEN,
    GREY,
    ORANGE,
    PURPLE,
    SKY,
    VERMILION,
    Canvas,
    render,
    row,
    seg_distance,
)
from gradekit.figures.mech import BAR, PIN, com_marker, draw_linkage
from gradekit.figures.sheet import (
    FIT,
    PT_PER_M,
    SIG,
    arrow_len,
    com_name,
    driver_key,
    force_text,
    heading,
    nice,
    sense,
    torque_arc,
    torque_text,
)
from gradekit.mechanics.forces import AppliedForce, Member
from gradekit.mechanics.model import Linkage, Prismatic, same_point
from gradekit.numbers import fmt
from gradekit.solving.pipeline import CaseResult, Result

FONT_FAMILY = FONT

KIND_COLOUR = {"pin": BLUE, "normal": SKY, "load": VERMILION, "gravity": GREEN, "inertia": PURPLE,
               "driver": ORANGE}
POLY_SIZE = 170.0  # largest extent of a force polygon, points


def force_name(pr, link: Linkage, f: AppliedForce, key: str) -> str:
    """F32 (force of link 3 on link 2), P, W2, Fi2, or the driver's answer key."""
    lab = pr.label
    if f.kind in ("pin", "normal"):
        j = next(j for j in link.joints if j.name == f.name)
        if isinstance(j, Prismatic):
            other = j.guide if f.body == j.block else j.block
        else:
            other = j.a if f.body == j.b else j.b
        return f"F{lab(other)}{lab(f.body)}"
    if f.kind == "gravity":
        return f"W{lab(f.body)}"
    if f.kind == "inertia":
        return f"Fi{lab(f.body)}"
    if f.kind == "driver":
        return key
    return f.name


def _case_tag(cr: CaseResult, many: bool) -> tuple[str, str]:
    return (f"-{cr.name}", f" ({cr.name})") if many and cr.name else ("", "")


def fbd(result: Result, cr: CaseResult, body: str, member: Member) -> Canvas:
    """Free-body diagram of *body*: the link alone with every force acting on it."""
    pr = result.problem
    link = cr.solution.linkage
    key = driver_key(result)
    pts = [f.point for f in member.forces] + [link.bodies[body].origin.pos()]
    lo, hi = np.min(pts, axis=0), np.max(pts, axis=0)
    span = max(float(np.max(hi - lo)), 1e-6)
    s = min(FIT[0] * 0.55 / span, 6 * PT_PER_M)
    centre = (lo + hi) / 2

    def T(p):
        return (np.asarray(p, float) - centre) * s

    cv = Canvas()
    P = draw_linkage(cv, link, T, bodies={body}, ground=False)
    keep = [n for n in link.points if _on_body(link, body, n)]  # ordered: labels placed deterministically
    points = ", ".join(pr.point(n) for n in keep)
    cv.describe(f"Free-body diagram of link {pr.label(body)} alone, with its points {points}; "
                f"{len(member.forces)} force{'s' if len(member.forces) != 1 else ''} act on it")
    mid = np.mean([T(p) for p in pts], axis=0)
    biggest = max((float(np.hypot(*f.vector)) for f in member.forces), default=0.0)
    st = cr.solution.states.get(body)
    if st is not None and (st.mass or st.inertia):
        com_marker(cv, T(st.g), f"com-{body}")
    arrows = []
    for f in member.forces:
        mag = float(np.hypot(*f.vector))
        u = f.vector / mag
        p = T(f.point)
        L = arrow_len(mag, biggest)
        colour = KIND_COLOUR.get(f.kind, BLACK)
        push = (p - u * (L + PIN + 1.0), p - u * (PIN + 1.0))  # head at the point
        pull = (p + u * (PIN + 1.0), p + u * (L + PIN + 1.0))  # tail at the point
        options = [push, pull] if float(np.dot(u, mid - p)) > 0 else [pull, push]
        drawn = [(t, h) for _f, t, h, _c in arrows]
        tail, head = options[1] if _crowded(options[0], drawn) and not _crowded(options[1], drawn) else options[0]
        if _clearance((tail, head), drawn) < 3.0:
            # on top of an arrow already drawn (a slide's normal force along the weight at one point):
            # the clearer side, then moved off the other arrow sideways, so that both show
            tail, head = max(options, key=lambda o: _clearance(o, drawn))
            if _clearance((tail, head), drawn) < 3.0:
                side = np.array([-u[1], u[0]]) * 8.0
                tail, head = tail + side, head + side
        cv.arrow(tail, head, colour, 1.4, gid=f"force-{f.name}")
        arrows.append((f, tail, head, colour))
    for name, c in member.couples:
        o = T(link.bodies[body].origin.pos())
        colour = ORANGE if name == "driver" else VERMILION
        torque_arc(cv, o, 16.0, c, colour, f"couple-{name}")
    if member.kind == "three-force" and member.concurrency is not None:
        k = T(member.concurrency)
        if float(np.hypot(*(k - mid))) < 2.5 * FIT[0] * 0.55:
            for f, _t, _h, _c in arrows:
                cv.line([T(f.point), k], GREY, 0.7, "--", z=1.0, obstacle=False)
            cv.line([k - 3.5, k + 3.5], BLACK, 1.0)
            cv.line([k + np.array([-3.5, 3.5]), k + np.array([3.5, -3.5])], BLACK, 1.0)
    for n in keep:
        cv.label(pr.point(n), P[n], BLACK, clear=PIN + BAR / 2 + 1.0, prefer=P[n] - mid)
    if member.kind == "three-force" and member.concurrency is not None:
        k = T(member.concurrency)
        if float(np.hypot(*(k - mid))) < 2.5 * FIT[0] * 0.55:
            cv.label("K", k, BLACK, clear=4.0)
    if st is not None and (st.mass or st.inertia) and com_name(pr, body) not in {pr.point(n) for n in keep}:
        cv.label(com_name(pr, body), T(st.g), BLACK, clear=5.0)
        cv.describe(f"Its mass centre {com_name(pr, body)} is marked with a quartered circle")
    for name, c in member.couples:
        o = T(link.bodies[body].origin.pos())
        colour = ORANGE if name == "driver" else VERMILION
        nm = key if name == "driver" else name
        txt = f"{nm} = {torque_text(pr, c)} {'ccw' if c > 0 else 'cw'}"
        cv.label(txt, o + np.array([0, 16.0]), colour, clear=3.0)
        cv.describe(f"{'Driving couple' if name == 'driver' else 'Couple'} {txt} ({sense(c)})")
    for f, tail, head, colour in arrows:
        txt = f"{force_name(pr, link, f, key)} = {force_text(pr, float(np.hypot(*f.vector)))}"
        cv.label(txt, [tail, (tail + head) / 2], colour, clear=3.0, prefer=tail - head)
        cv.describe(f"{_FORCE_WORDS.get(f.kind, 'Force')} {txt} at {_at(pr, link, f.point, body, st)}, "
                    f"pointing {heading(f.vector)}")
    if member.kind == "three-force" and member.concurrency is not None:
        cv.describe("The three lines of action meet at one point, K (dashed lines)")
    return cv


_FORCE_WORDS = {"pin": "Pin force", "normal": "Normal force of the slide", "load": "Load",
                "gravity": "Weight", "inertia": "Inertia force", "driver": "Driving force"}


def _at(pr, link: Linkage, point, body: str, st) -> str:
    """Where a force acts, by the sheet's name of the point (or the link's mass centre)."""
    name = link.point_at(point)
    if name:
        return pr.point(name)
    if st is not None and same_point(np.asarray(point, float), st.g):
        return f"the mass centre {com_name(pr, body)}"
    return f"a line of action offset from the mass centre {com_name(pr, body)}"


def _crowded(seg, drawn, near: float = 6.0) -> bool:
    """Whether arrow *seg* runs within *near* points of an arrow already drawn."""
    return any(seg_distance(seg[0], seg[1], t, h) < near for t, h in drawn)


def _clearance(seg, drawn) -> float:
    """How far (points) arrow *seg* runs from the nearest arrow already drawn."""
    return min((seg_distance(seg[0], seg[1], t, h) for t, h in drawn), default=math.inf)


def _on_body(link: Linkage, body: str, point: str) -> bool:
    b = link.bodies[body]
    p = np.asarray(link.points[point].pos())
    if same_point(p, b.origin.pos()):
        return True
    for j in link.joints:
        if body in (getattr(j, "a", None), getattr(j, "b", None), getattr(j, "block", None),
                    getattr(j, "guide", None)) and same_point(p, j.point.pos()):
            return True
    return False


def polygon(result: Result, cr: CaseResult, member: Member, title: str) -> Canvas:
    """The force polygon of *member*, head to tail, to a stated force scale."""
    pr = result.problem
    link = cr.solution.linkage
    key = driver_key(result)
    poly = member.polygon
    span = max(float(np.max(poly.max(axis=0) - poly.min(axis=0))), 1e-12)
    s = POLY_SIZE / span  # points per newton
    cv = Canvas()
    V = (poly - (poly.max(axis=0) + poly.min(axis=0)) / 2) * s
    mid = V.mean(axis=0)
    k = len(member.forces)
    # Collinear forces (a two-force member, a load along a slide) close a polygon of zero area:
    # the arrows would lie on top of each other, so each is drawn beside the line, side by side.
    edges = [V[i + 1] - V[i] for i in range(k)]
    u = max(edges, key=lambda e: float(np.hypot(*e)))
    u = u / max(float(np.hypot(*u)), 1e-12)
    normal = np.array([-u[1], u[0]])
    flat = k > 1 and float(np.max(np.abs((V - V[0]) @ normal))) < 0.06 * POLY_SIZE
    shift = [normal * (10.0 * (i - (k - 1) / 2)) if flat else np.zeros(2) for i in range(k)]
    for i, f in enumerate(member.forces):
        cv.arrow(V[i] + shift[i], V[i + 1] + shift[i], KIND_COLOUR.get(f.kind, BLACK), 1.4, gid=f"poly-{f.name}")
    for i, f in enumerate(member.forces):
        a, b = V[i] + shift[i], V[i + 1] + shift[i]
        m, d = (a + b) / 2, b - a
        n = np.array([-d[1], d[0]])
        if flat:
            n = shift[i] if float(np.hypot(*shift[i])) > 0 else normal
        elif float(np.dot(n, m - mid)) < 0:
            n = -n
        cv.label(force_name(pr, link, f, key), [m, a + d * 0.3, a + d * 0.7],
                 KIND_COLOUR.get(f.kind, BLACK), clear=2.0, prefer=n)
    if flat:
        x0, y0, _, _ = cv.extent()
        cv.text((x0, y0 - 10.0), "collinear forces: drawn side by side", GREY, 7.5, ha="left")
        cv.describe("A note under it: collinear forces: drawn side by side")
    names = [force_name(pr, link, f, key) for f in member.forces]
    steps = "; ".join(f"{nm} = {force_text(pr, float(np.hypot(*f.vector)))} pointing {heading(f.vector)}"
                      for nm, f in zip(names, member.forces, strict=True))
    cv.describe(f"{title}: the forces drawn head to tail in the order {', '.join(names)}: {steps}. The head of "
                f"{names[-1]} returns to the tail of {names[0]}, so the polygon closes: the forces add up to zero"
               )
    # force scale bar
    fu = pr.units["force"]
    per_pt = units.convert(1.0 / s, "N", fu)
    bar_f = nice(POLY_SIZE / 3 * per_pt)
    cv.scale_bar(bar_f / per_pt, f"{fmt(bar_f)} {units.pretty(fu)}")
    cv.describe(f"Force scale bar {fmt(bar_f)} {units.pretty(fu)}")
    _title(cv, title)
    return cv


def _title(cv: Canvas, text: str) -> None:
    x0, _, x1, y1 = cv.extent()
    cv.text(((x0 + x1) / 2, y1 + 11.0), text, BLACK, 9.0)


def motion_polygon(result: Result, cr: CaseResult, which: str) -> Canvas:
    """Velocity (*which* = "vel") or acceleration ("acc") polygon: every point's image from the pole o."""
    pr = result.problem
    link = cr.solution.linkage
    lu = pr.units["length"]
    unit = f"{lu}/s" if which == "vel" else pr.units.get("acceleration", f"{lu}/s**2")
    si = "m/s" if which == "vel" else "m/s**2"
    sym = "v" if which == "vel" else "a"
    colour = BLUE if which == "vel" else VERMILION
    vec = {pr.point(n): np.asarray(p.vel() if which == "vel" else p.acc(), float) for n, p in link.points.items()}
    for body, st in cr.solution.states.items():
        if st.mass or st.inertia:
            g = np.asarray(st.v_g if which == "vel" else st.a_g, float)
            if not any(same_point(g, v) for v in vec.values()):
                vec[com_name(pr, body)] = g
    biggest = max(float(np.hypot(*v)) for v in vec.values())
    cv = Canvas()
    if biggest <= 0:
        cv.text((0.0, 0.0), "all points at rest")
        return cv
    s = POLY_SIZE / biggest
    img = {n: v * s for n, v in vec.items()}
    o = np.zeros(2)
    still = [n for n, v in vec.items() if float(np.hypot(*v)) < 1e-9 * biggest]
    bars = [(pr.point(a), pr.point(b)) for pairs in _bars(link).values() for a, b in pairs]
    for a, b in bars:  # relative motion of two points of one link: dashed
        if a in img and b in img and a not in still or b not in still:
            cv.line([img[a], img[b]], GREY, 0.8, "--", z=1.0)
    for n, v in img.items():
        if n not in still:
            cv.arrow(o, v, colour, 1.3, gid=f"{which}-{n}")
    cv.circle(o, 2.0, BLACK, BLACK, 0.5)
    pole = "o" + (f" ({', '.join(still)})" if still else "")
    cv.label(pole, o, BLACK, clear=3.0, priority=-1)
    mid = np.mean(list(img.values()), axis=0)
    word = "Velocity" if which == "vel" else "Acceleration"
    cv.describe(f"{word} polygon: an arrow from the pole o to the image of each moving point; the pole is "
                f"labelled {pole}" + (f", where the points at rest ({', '.join(still)}) have their images" if still
                                      else ""))
    legend = []
    for n, v in img.items():
        if n in still:
            continue
        val = fmt(units.convert(float(np.hypot(*vec[n])), si, unit), SIG)
        # Only the name at the arrow's head, pushed outward along it: the images of neighbouring points
        # have their heads close together, where a whole "aC = ..." beside one head reads as the next
        # one's; the values are listed under the polygon.
        out = v / max(float(np.hypot(*v)), 1e-12)
        side = (v - mid) / max(float(np.hypot(*(v - mid))), 1e-12)
        cv.label(f"{sym}{n}", [v], colour, clear=3.0, prefer=out + 0.3 * side)
        legend.append(f"{sym}{n} = {val} {units.pretty(unit)}")
        cv.describe(f"{legend[-1]}, pointing {heading(vec[n])}")
    cv.describe("Dashed lines join the images of two points of one link: their relative "
                + ("velocity" if which == "vel" else "acceleration"))
    per_pt = units.convert(1.0 / s, si, unit)
    bar_v = nice(POLY_SIZE / 3 * per_pt)
    y = cv.scale_bar(bar_v / per_pt, f"{fmt(bar_v)} {units.pretty(unit)}")
    cv.describe(f"Scale bar {fmt(bar_v)} {units.pretty(unit)}")
    x0 = cv.extent()[0]
    for i, line in enumerate(legend):
        cv.text((x0, y - 14.0 - 11.0 * i), line, colour, ha="left")
    return cv


def _bars(link: Linkage) -> dict[str, list[tuple[str, str]]]:
    from gradekit.mechanics.mechanisms import KINDS

    return KINDS[link.kind].bars


@dataclass(frozen=True)
class Plot:
    """A plotted curve (a matplotlib Figure) and its text alternative."""

    figure: object
    alt: str


def torque_cycle(result: Result, n: int = 72):
    """The driving torque (or force) over a full crank cycle, the asked positions marked."""
    return torque_cycle_plot(result, n).figure


def torque_cycle_plot(result: Result, n: int = 72) -> Plot:
    """`torque_cycle` with its text alternative (the curve's range and the marked positions)."""
    import dataclasses

    import numpy as np
    from matplotlib.figure import Figure

    from gradekit.solving.pipeline import solve_many

    pr = result.problem
    theta = pr.inputs["theta"]
    tp = pr.parameters[theta]
    base = {k: v for k, v in result.values.items() if k in pr.parameters and not pr.parameters[k].expr}
    full_turn = units.convert(360.0, "deg", tp.unit)
    drv_force = result.cases[0].solution.linkage.driver.kind == "force"
    out_unit = pr.units["force"] if drv_force else pr.units["torque"]
    si = "N" if drv_force else "N*m"
    xs = [full_turn * k / n for k in range(n + 1)]
    # one batch over the turn; the problem's cases would fix the crank angle, so none here
    batch = solve_many(dataclasses.replace(pr, cases={}), {**base, theta: np.asarray(xs)}, n + 1)
    drv, unit = batch.cases[0].results["driver"]
    ys = [math.nan if batch.refused.mask[i] else units.convert(float(drv[i]), unit, out_unit)
          for i in range(n + 1)]
    fig = Figure(figsize=(5.6, 2.9), dpi=72)
    ax = fig.add_axes((0.13, 0.17, 0.84, 0.72))
    ax.plot(xs, ys, color=BLUE, lw=1.4)
    ax.axhline(0.0, color=GREY, lw=0.6)
    key = driver_key(result)
    marks = sorted((c.values[theta], units.convert(c.solution.driver, si, out_unit), c.name) for c in result.cases)
    ax.plot([m[0] for m in marks], [m[1] for m in marks], "o", color=VERMILION, ms=5, zorder=5)
    finite = [y for y in ys if math.isfinite(y)] + [m[1] for m in marks]
    lo, hi = min(finite), max(finite)
    pad = 0.18 * (hi - lo or 1.0)
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlim(0.0, full_turn)
    for i, (x, y, name) in enumerate(marks):
        up = (i % 2 == 0) if y < hi - pad else False
        # parse_math off: names from a problem file are text, never mathtext (a "$x^$" would not parse)
        ax.annotate(f"{name}: {fmt(y, SIG)}", (x, y), xytext=(0, 8 if up else -12), textcoords="offset points",
                    ha="center", va="center", fontsize=7.5, color=VERMILION, family=FONT_FAMILY, parse_math=False)
    u = units.pretty(tp.unit)
    xlabel = f"crank angle {tp.symbol or theta} ({u})"
    ylabel = f"{key} ({units.pretty(out_unit)})"
    title = f"Driving {'force' if drv_force else 'torque'} {key} over one crank turn"
    ax.set_xlabel(xlabel, fontsize=8, family=FONT_FAMILY, parse_math=False)
    ax.set_ylabel(ylabel, fontsize=8, family=FONT_FAMILY, parse_math=False)
    ax.tick_params(labelsize=7.5)
    if units.pretty(tp.unit) == "°":
        ax.set_xticks([0, 60, 120, 180, 240, 300, 360])
    ax.set_title(title, fontsize=9, family=FONT_FAMILY, parse_math=False)
    ou = units.pretty(out_unit)
    alt = (f"{title}: a line plot of {ylabel} against {xlabel} from 0 to {fmt(full_turn)} {u}; the curve runs "
           f"from {fmt(min(finite), SIG)} {ou} to {fmt(max(finite), SIG)} {ou}. Marked positions: "
           + "; ".join(f"{name} at {fmt(x)} {u}: {fmt(y, SIG)} {ou}" for x, y, name in marks) + ".")
    return Plot(fig, alt)


def key_figure_specs(result: Result) -> list[tuple[str, str, object]]:
    """(slug, caption, make) of every key figure; *make()* returns its matplotlib Figure.

    Slugs are lower-case letters, digits and hyphens, unique within the variant.
    """
    return [(slug, cap, lambda make=make: _as_figure(make())) for slug, cap, make in key_drawings(result)]


def _as_figure(drawn):
    if isinstance(drawn, Plot):
        return drawn.figure
    return render(drawn) if isinstance(drawn, Canvas) else drawn


def key_drawings(result: Result) -> list[tuple[str, str, object]]:
    """(slug, caption, make) of every key figure; *make()* returns a `Canvas` (a display list in
    points, for `canvas.svg`) or, for a plotted curve, a `Plot` (a matplotlib Figure and its text
    alternative)."""
    import re

    out = []
    seen: set[str] = set()
    for slug, cap, make in _specs(result):
        slug = re.sub(r"[^a-z0-9]+", "-", slug.lower()).strip("-") or "figure"
        base, n = slug, 2
        while slug in seen:
            slug, n = f"{base}-{n}", n + 1
        seen.add(slug)
        out.append((slug, cap, make))
    return out


def _specs(result: Result) -> list[tuple[str, str, object]]:
    pr = result.problem
    many = len(result.cases) > 1
    out: list[tuple[str, str, object]] = []
    for cr in result.cases:
        tag, ctag = _case_tag(cr, many)
        for body, member in cr.solution.total.members.items():
            if not member.forces:
                continue
            lab = pr.label(body)
            kind = {"two-force": "a two-force member", "three-force": "a three-force member",
                    "two-forces-and-couple": "two forces and a couple"}.get(member.kind, "")
            with_poly = len(member.forces) >= 2 and member.kind != "two-force"
            cap = (f"Link {lab}{ctag}: free-body diagram" + (" and force polygon" if with_poly else "")
                   + (f" ({kind})" if kind else ""))
            if member.kind == "three-force" and member.concurrency is not None:
                cap += "; K is the point where the three lines of action meet"
            out.append((f"fbd-{lab}{tag}", cap,
                        lambda cr=cr, body=body, member=member: _fbd_figure(result, cr, body, member)))
        groups = cr.solution.groups
        # Sub-problem figures only where the problem asks for superposition parts (driver@F2, …):
        # a figure carries only what its problem needs.
        if len(groups) > 1 and any("@" in a.of for a in pr.answers):
            for gname, g in groups.items():
                if any(len(m.forces) >= 2 and m.kind != "two-force" for m in g.members.values()):
                    panels = _maker(result, cr, g)
                    glab = gname.split(":", 1)[1] if ":" in gname else gname
                    gl = f"inertia of link {pr.label(glab)}" if gname.startswith("inertia:") else gname
                    slug = f"group-{pr.label(glab) if ':' in gname else gname}{tag}"
                    out.append((slug, f"Sub-problem with {gl} alone{ctag}: force polygons", panels))
        if pr.analysis == "dynamic":
            for which, word in (("vel", "Velocity"), ("acc", "Acceleration")):
                out.append((f"{which}-polygon{tag}", f"{word} polygon{ctag}: images of the points from the pole o; "
                            "dashed lines join points of one link (relative motion)",
                            lambda cr=cr, which=which: motion_polygon(result, cr, which)))
    if many and isinstance(pr.inputs.get("theta"), str) and pr.inputs["theta"] in pr.parameters:
        names = ", ".join(str(c.name) for c in result.cases)
        out.append(("torque-cycle", f"Driving torque over one crank turn; the asked positions {names} marked",
                    lambda: torque_cycle_plot(result)))
    return out


def _fbd_figure(result: Result, cr: CaseResult, body: str, member: Member):
    lab = result.problem.label(body)
    left = fbd(result, cr, body, member)
    _title(left, f"Free-body diagram of link {lab}")
    panels = [left]
    if len(member.forces) >= 2 and member.kind != "two-force":
        panels.append(polygon(result, cr, member, f"Force polygon of link {lab}"))
    return row(panels)


def _maker(result: Result, cr: CaseResult, g):
    def make():
        return row([polygon(result, cr, m, f"Link {result.problem.label(b)}") for b, m in g.members.items()
                    if len(m.forces) >= 2 and m.kind != "two-force"])
    return make




