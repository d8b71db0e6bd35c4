"""The instructor's answer-key figures: free-body diagrams, force polygons, velocity and acceleration
polygons and the input torque over a crank cycle."""

from __future__ import annotations

import math

import numpy as np

from gradekit import units
from gradekit.figures.assignment import FIT, PT_PER_M, arrow_len, driver_key, force_text, nice, torque_arc, torque_text
from gradekit.figures.canvas import BLACK, BLUE, GREEN, GREY, ORANGE, PURPLE, SKY, VERMILION, Canvas, render, row
from gradekit.figures.mech import BAR, PIN, com_marker, draw_linkage, mech_extent
from gradekit.mechanics.forces import AppliedForce, Member
from gradekit.mechanics.model import GROUND, Linkage, Prismatic
from gradekit.pipeline import CaseResult, Result
from gradekit.report import fmt

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
    lo, hi = mech_extent(link) if False else (np.min(pts, axis=0), np.max(pts, axis=0))
    span = max(float(np.max(hi - lo)), 1e-6)
    s = min(FIT[0] * 0.55 / span, 6 * PT_PER_M)
    centre = (lo + hi) / 2

    def T(p):
        return (np.asarray(p, float) - centre) * s

    cv = Canvas()
    P = draw_linkage(cv, link, T, bodies={body}, ground=False)
    keep = {n for n, p in link.points.items() if _on_body(link, body, n)}
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
        if float(np.dot(u, mid - p)) > 0:  # pushes towards the body: head at the point
            head = p - u * (PIN + 1.0)
            tail = head - u * L
        else:
            tail = p + u * (PIN + 1.0)
            head = tail + u * L
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
    if st is not None and (st.mass or st.inertia):
        cv.label(f"G{pr.label(body)}", T(st.g), BLACK, clear=5.0)
    for name, c in member.couples:
        o = T(link.bodies[body].origin.pos())
        colour = ORANGE if name == "driver" else VERMILION
        nm = key if name == "driver" else name
        cv.label(f"{nm} = {torque_text(pr, c)} {'ccw' if c > 0 else 'cw'}", o + np.array([0, 16.0]),
                 colour, clear=3.0)
    for f, tail, head, colour in arrows:
        txt = f"{force_name(pr, link, f, key)} = {force_text(pr, float(np.hypot(*f.vector)))}"
        cv.label(txt, [tail, (tail + head) / 2], colour, clear=3.0, prefer=tail - head)
    return cv


def _on_body(link: Linkage, body: str, point: str) -> bool:
    b = link.bodies[body]
    p = np.asarray(link.points[point].pos())
    if np.allclose(p, b.origin.pos()):
        return True
    for j in link.joints:
        if body in (getattr(j, "a", None), getattr(j, "b", None), getattr(j, "block", None),
                    getattr(j, "guide", None)) and np.allclose(p, j.point.pos()):
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
    for i, f in enumerate(member.forces):
        cv.arrow(V[i], V[i + 1], KIND_COLOUR.get(f.kind, BLACK), 1.4, gid=f"poly-{f.name}")
    for i, f in enumerate(member.forces):
        m = (V[i] + V[i + 1]) / 2
        d = V[i + 1] - V[i]
        n = np.array([-d[1], d[0]])
        if float(np.dot(n, m - mid)) < 0:
            n = -n
        cv.label(force_name(pr, link, f, key), [m, V[i] + d * 0.3, V[i] + d * 0.7],
                 KIND_COLOUR.get(f.kind, BLACK), clear=2.0, prefer=n)
    # force scale bar
    fu = pr.units["force"]
    per_pt = units.convert(1.0 / s, "N", fu)
    bar_f = nice(POLY_SIZE / 3 * per_pt)
    Lp = bar_f / per_pt
    x0, y0, _, _ = cv.extent()
    y = y0 - 12.0
    cv.line([(x0, y), (x0 + Lp, y)], BLACK, 1.2, cap="butt")
    for xx in (x0, x0 + Lp):
        cv.line([(xx, y - 3), (xx, y + 3)], BLACK, 0.8, cap="butt")
    cv.text((x0 + Lp + 4, y), f"{fmt(bar_f)} {units.pretty(fu)}", ha="left")
    _title(cv, title)
    return cv


def _title(cv: Canvas, text: str) -> None:
    x0, _, x1, y1 = cv.extent()
    cv.text(((x0 + x1) / 2, y1 + 10.0), text, BLACK, 8.5, weight="bold")


def member_figures(result: Result) -> list[tuple[str, str, object]]:
    pr = result.problem
    many = len(result.cases) > 1
    out = []
    for cr in result.cases:
        tag, ctag = _case_tag(cr, many)
        for body, member in cr.solution.total.members.items():
            if not member.forces:
                continue
            lab = pr.label(body)
            left = fbd(result, cr, body, member)
            _title(left, f"Free-body diagram of link {lab}")
            panels = [left]
            if len(member.forces) >= 2:
                panels.append(polygon(result, cr, member, f"Force polygon of link {lab}"))
            kind = {"two-force": "a two-force member", "three-force": "a three-force member",
                    "two-forces-and-couple": "two forces and a couple"}.get(member.kind, "")
            cap = f"Link {lab}{ctag}: free-body diagram and force polygon" + (f" ({kind})" if kind else "")
            if member.kind == "three-force" and member.concurrency is not None:
                cap += "; K is the point where the three lines of action meet"
            out.append((f"fbd-{lab}{tag}", cap, render(row(panels))))
        groups = cr.solution.groups
        if len(groups) > 1:
            for gname, g in groups.items():
                panels = []
                for body, member in g.members.items():
                    if len(member.forces) >= 2:
                        panels.append(polygon(result, cr, member, f"Link {pr.label(body)}"))
                if panels:
                    glab = gname.split(":", 1)[1] if ":" in gname else gname
                    gl = f"inertia of link {pr.label(glab)}" if gname.startswith("inertia:") else gname
                    slug = f"group-{pr.label(glab) if ':' in gname else gname}{tag}"
                    out.append((slug, f"Sub-problem with {gl} alone{ctag}: force polygons", render(row(panels))))
    return out


__all__ = ["member_figures", "GREY", "GROUND", "math"]
