"""The route of a worked key, as the lines a student writes: loop closure, position, velocity and
acceleration equations, inertia forces, each link's equilibrium (symbolic, with numbers, solved),
the assembled system A·x = b, the graphical construction and the superposition sum.

Every line is Typst markup built from one solved position (`Solution`) in the problem's display
units, with the problem's own link and point names. Numbers are printed through `num`, so what a
test parses back from a line is what the key prints.
"""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import numpy as np

from gradekit import units
from gradekit.documents.typeset import Typ, formula, num, text
from gradekit.mechanics.mechanisms import KINDS, carriers
from gradekit.mechanics.model import GROUND, Prismatic
from gradekit.solving.report import display_unit, shown_value

SIG = 5  # significant figures of every evaluated term
COEF_SIG = 4  # of a coefficient (a moment arm, a direction cosine) and of the printed matrix


def m(s: str) -> str:
    """Text inside Typst math, quoted so that ``01`` or ``crank`` print as written."""
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def n(x: float, sig: int = SIG) -> str:
    return str(num(x, sig))


def _u(u: str) -> str:
    return m(units.pretty(u)) if units.pretty(u) else ""


def _vec(v, sig: int = SIG) -> str:
    """``(x, y)``; a component below the vector's magnitude × 1e-12 is a zero's round-off and prints 0."""
    size = float(np.hypot(v[0], v[1]))
    return f"({n(shown_value(v[0], size), sig)}, {n(shown_value(v[1], size), sig)})"


def _signed(terms: list[tuple[float, str]], sig: int = SIG, zeros: bool = False) -> str:
    """``a + b − c`` from (value, suffix) terms; zero terms dropped unless *zeros*; '0' when none are left."""
    out = []
    for v, suffix in terms:
        s = n(abs(v), sig)
        if s == "0" and not zeros:
            continue
        s = f"{s} {suffix}".strip() if suffix else s
        out.append(("−" if v < 0 else "+") + " " + s)
    if not out:
        return "0"
    text = " ".join(out)
    return text[2:] if text.startswith("+ ") else "−" + text[2:]


def _clean(v: float, scale: float) -> float:
    return 0.0 if abs(v) <= 1e-9 * scale else v


class Names:
    """The problem's own names: links (`label`), points (`point`), and math symbols from them."""

    def __init__(self, p, link) -> None:
        self.p = p
        self.link = link

    def body(self, b: str) -> str:
        return m(self.p.label(b))

    def pt(self, name: str) -> str:
        return self.p.point(name)

    def r(self, a: str, b: str) -> str:
        return f"arrow(r)_({m(self.pt(a) + self.pt(b))})"

    def point_at(self, pos) -> str:
        return self.link.point_at(pos)


# ---------------------------------------------------------------------------------------- kinematics


def _own_names(p, kind) -> str:
    """The kind's description of its branches, with the problem's own point names."""
    pattern = r"\b(" + "|".join(sorted(map(re.escape, kind.points), key=len, reverse=True)) + r")\b"
    return re.sub(pattern, lambda mt: p.point(mt.group(1)), kind.branch)


def needs_motion(p) -> bool:
    """Velocities and accelerations are needed: inertia forces, or an answer asks for them."""
    asks = any(a.of.startswith(("omega[", "alpha[", "v[", "a[", "aG[", "vG[")) for a in p.answers)
    return p.analysis == "dynamic" or asks


def _slide_axis(link, names: Names, a: str, b: str):
    """The unit vector of the prismatic joint at either end of segment a→b (None if rigid)."""
    for j in link.joints:
        if isinstance(j, Prismatic):
            at = names.point_at(j.point.pos())
            if at in (a, b):
                ang = float(j.axis.v)
                return np.array([math.cos(ang), math.sin(ang)]), at
    return None, ""


def kinematics(p, sol) -> dict:
    """Loop closure, position solution, velocity and acceleration equations, mass centres."""
    link = sol.linkage
    nm = Names(p, link)
    kind = KINDS[p.kind]
    lu = p.units["length"]
    vu, au = display_unit(p, "m/s"), display_unit(p, "m/s**2")
    kl, kv, ka = units.factor("m", lu), units.factor("m/s", vu), units.factor("m/s**2", au)
    pts = link.points
    angle = {b: math.degrees(float(link.bodies[b].angle.v)) % 360.0 for b in link.bodies}
    omega = {b: float(link.bodies[b].angle.d) for b in link.bodies}
    alpha = {b: float(link.bodies[b].angle.dd) for b in link.bodies}
    omega[GROUND] = alpha[GROUND] = 0.0
    th = {b: f"theta_({nm.body(b)})" for b in link.bodies}
    w = {b: f"omega_({nm.body(b)})" for b in link.bodies}
    al = {b: f"alpha_({nm.body(b)})" for b in link.bodies}
    scale = max(float(np.max(np.abs(q.pos()))) for q in pts.values()) or 1.0
    vscale = max(float(np.max(np.abs(q.vel()))) for q in pts.values()) or 1.0
    ascale = max(float(np.max(np.abs(q.acc()))) for q in pts.values()) or 1.0

    closure, position = [], []
    for left, right in kind.closure:
        def side(chain):
            return " + ".join(nm.r(a, b) for a, b, _ in chain)
        closure.append(formula(f"{side(left)} = {side(right)}"))
        for a, b, _ in (*left, *right):
            r = (pts[b].pos() - pts[a].pos()) * kl
            if float(np.hypot(*r)) <= 1e-12 * scale * kl:
                continue
            closure.append(formula(f"{nm.r(a, b)} = {n(float(np.hypot(*r)))} {_u(lu)} angle "
                               f"{n(math.degrees(math.atan2(r[1], r[0])) % 360.0, SIG)} degree = "
                               f"{_vec([_clean(c, scale * kl) for c in r])} {_u(lu)}"))
    branch = {1: "open", -1: "crossed"}.get(p.branch, str(p.branch))
    for b in link.bodies:
        position.append(formula(f"{th[b]} = {n(angle[b])} degree"))
    result = {"closure": closure, "position": position,
              "branch": f"{branch}: {_own_names(p, kind)}" if kind.closure else "",
              "velocity": [], "acceleration": [], "centres": [], "slides": False}
    if not needs_motion(p):
        return result

    known = {link.input_body, GROUND}
    carried = carriers(p.kind)
    vel, acc = [], []
    for left, right in kind.closure:
        new = [b for _, _, b in (*left, *right) if b not in known]
        vs, vn, asy, an = [], [], [], []
        unknown_v, unknown_a = [], []
        for chain in (left, right):
            cs, cn, ds, dn = [], [], [], []
            for a, b, body in chain:
                r = pts[b].pos() - pts[a].pos()
                if float(np.hypot(*r)) <= 1e-12 * scale:
                    continue
                perp = np.array([-r[1], r[0]])
                slides = body not in carried.get(b, ())
                u, at = _slide_axis(link, nm, a, b) if slides else (None, "")
                slides = u is not None
                rs = nm.r(a, b)
                if body != GROUND:
                    cs.append(f"{w[body]} hat(k) times {rs}")
                    ds.append(f"{al[body]} hat(k) times {rs} - {w[body]}^2 {rs}")
                    if body in known:
                        cn.append(_vec([_clean(c, vscale * kv) for c in omega[body] * perp * kv]))
                        acc_known = (alpha[body] * perp - omega[body] ** 2 * r) * ka
                        dn.append(_vec([_clean(c, ascale * ka) for c in acc_known]))
                    else:
                        unknown_v.append(w[body])
                        unknown_a.append(al[body])
                        cn.append(f"{w[body]} {_vec(perp * kl, COEF_SIG)}")
                        cent = -omega[body] ** 2 * r * ka
                        cent = [_clean(c, ascale * ka) for c in cent]
                        dn.append(f"{al[body]} {_vec(perp * kl, COEF_SIG)} + {_vec(cent)}")
                if slides:
                    s_sym = f"dot(s)_({m(nm.pt(at))})"
                    a_sym = f"dot.double(s)_({m(nm.pt(at))})"
                    cs.append(f"{s_sym} hat(u)")
                    ds.append(f"{a_sym} hat(u)" + (f" + 2 {w[body]} hat(k) times {s_sym} hat(u)"
                                                   if body != GROUND else ""))
                    sdot = float((pts[b].vel() - pts[a].vel() - omega[body] * perp) @ u)
                    unknown_v.append(s_sym)
                    unknown_a.append(a_sym)
                    cn.append(f"{s_sym} {_vec(u, COEF_SIG)}")
                    cor = 2 * omega[body] * sdot * np.array([-u[1], u[0]]) * ka
                    dn.append(f"{a_sym} {_vec(u, COEF_SIG)}"
                              + (f" + {_vec([_clean(c, ascale * ka) for c in cor])}" if body != GROUND else ""))
                    result.setdefault("_slides", {})[at] = (sdot, u)
                    result["slides"] = result["slides"] or body != GROUND
                    arel = pts[b].acc() - pts[a].acc() - (alpha[body] * perp - omega[body] ** 2 * r) - cor / ka
                    result.setdefault("_sddot", {})[at] = float(arel @ u) * ka
            vs.append(" + ".join(cs) or "0")
            vn.append(" + ".join(cn) or "0")
            asy.append(" + ".join(ds) or "0")
            an.append(" + ".join(dn) or "0")
        vel.append(formula(f"{vs[0]} = {vs[1]}"))
        vel.append(Typ(formula(f"{vn[0]} = {vn[1]}") + f" #h(0.5em) ({text(units.pretty(vu))})"))
        acc.append(formula(f"{asy[0]} = {asy[1]}"))
        acc.append(Typ(formula(f"{an[0]} = {an[1]}") + f" #h(0.5em) ({text(units.pretty(au))})"))
        sol_v, sol_a = [], []
        for b in dict.fromkeys(new):
            sol_v.append(f"{w[b]} = {n(omega[b])} {_u('rad/s')}")
            sol_a.append(f"{al[b]} = {n(alpha[b])} {_u('rad/s**2')}")
            known.add(b)
        sdd = result.pop("_sddot", {})
        for at, (sdot, _axis) in result.pop("_slides", {}).items():
            sol_v.append(f"dot(s)_({m(nm.pt(at))}) = {n(sdot * kv)} {_u(vu)}")
            sol_a.append(f"dot.double(s)_({m(nm.pt(at))}) = {n(sdd.get(at, 0.0))} {_u(au)}")
        if sol_v:
            vel.append(formula("arrow.double.r " + ", #h(0.6em) ".join(sol_v)))
            acc.append(formula("arrow.double.r " + ", #h(0.6em) ".join(sol_a)))
    result["velocity"], result["acceleration"] = vel, acc
    # velocity and acceleration of each named point, then of each mass centre
    for name, q in pts.items():
        if name.startswith("+") or float(np.hypot(*q.vel())) == 0 and float(np.hypot(*q.acc())) == 0:
            continue
        v, a = q.vel() * kv, q.acc() * ka
        result["centres"].append(formula(
            f"arrow(v)_({m(nm.pt(name))}) = {_vec(v)} {_u(vu)}, #h(0.4em) abs(arrow(v)_({m(nm.pt(name))})) = "
            f"{n(float(np.hypot(*v)))} {_u(vu)}; #h(0.8em) arrow(a)_({m(nm.pt(name))}) = {_vec(a)} {_u(au)}, "
            f"#h(0.4em) abs(arrow(a)_({m(nm.pt(name))})) = {n(float(np.hypot(*a)))} {_u(au)}"))
    for b, st in sol.states.items():
        if not (st.mass or st.inertia):
            continue
        o = link.bodies[b].origin
        oname = nm.pt(nm.point_at(o.pos()))
        rg = (np.asarray(st.g) - o.pos())
        if float(np.hypot(*rg)) <= 1e-12 * scale:
            line = f"arrow(a)_(G {nm.body(b)}) = arrow(a)_({m(oname)}) = {_vec(np.asarray(st.a_g) * ka)} {_u(au)}"
        else:
            perp = np.array([-rg[1], rg[0]])
            ta = alpha[b] * perp * ka
            tc = -omega[b] ** 2 * rg * ka
            line = (f"arrow(a)_(G {nm.body(b)}) = arrow(a)_({m(oname)}) + {al[b]} hat(k) times arrow(r)_({m(oname)} G) "
                    f"- {w[b]}^2 arrow(r)_({m(oname)} G) = {_vec(o.acc() * ka)} + {_vec(ta)} + {_vec(tc)} = "
                    f"{_vec(np.asarray(st.a_g) * ka)} {_u(au)}")
        ag = np.asarray(st.a_g) * ka
        mag = float(np.hypot(*ag))
        line += (f", #h(0.4em) abs(arrow(a)_(G {nm.body(b)})) = {n(mag)} {_u(au)} angle "
                 f"{n(math.degrees(math.atan2(ag[1], ag[0])) % 360.0) if mag else '0'} degree")
        result["centres"].append(formula(line))
    return result


# ------------------------------------------------------------------------------------------- inertia


def inertia(p, sol) -> list[Typ]:
    """−m·a_G and −I·α of each link with numbers; h = I·α/(m·a_G) where the problem uses offsets."""
    nm = Names(p, sol.linkage)
    mu, iu, fu, tu, lu = (p.units.get("mass", "kg"), p.units.get("inertia", "kg*m**2"), p.units["force"],
                          p.units["torque"], p.units["length"])
    au = p.units.get("acceleration", "m/s**2")
    offsets = p.method == "graphical" or any(a.of.startswith("h[") for a in p.answers)
    out = []
    for b, st in sol.states.items():
        if not (st.mass or st.inertia):
            continue
        L = nm.body(b)
        ag = np.asarray(st.a_g)
        fi = np.asarray(st.inertia_force)
        fim = float(np.hypot(*fi)) * units.factor("N", fu)
        mass = units.convert(st.mass, "kg", mu)
        ang = math.degrees(math.atan2(fi[1], fi[0])) % 360.0 if fim else 0.0
        out.append(formula(
            f"arrow(F)_(i {L}) = -m_({L}) arrow(a)_(G {L}) = -({n(mass)} {_u(mu)}) "
            f"{_vec(ag * units.factor('m/s**2', au))} {_u(au)} = {_vec(fi * units.factor('N', fu))} {_u(fu)}, "
            f"#h(0.4em) abs(arrow(F)_(i {L})) = {n(fim)} {_u(fu)} angle {n(ang)} degree"))
        ci = float(st.inertia_couple) * units.factor("N*m", tu)
        out.append(formula(
            f"C_(i {L}) = -I_(G {L}) alpha_({L}) = -({n(units.convert(st.inertia, 'kg*m**2', iu))} {_u(iu)}) "
            f"({n(st.alpha)} {_u('rad/s**2')}) = {n(ci)} {_u(tu)}"))
        if offsets and fim and ci:
            h = st.offset * units.factor("m", lu)
            out.append(Typ(
                formula(f"h_({L}) = (I_(G {L}) abs(alpha_({L}))) / (m_({L}) abs(arrow(a)_(G {L}))) = "
                        f"abs(C_(i {L})) / abs(arrow(F)_(i {L})) = {n(h)} {_u(lu)}")
                + f" #h(0.4em) (the offset force {formula(f'arrow(F)_(i {L})')} acts at {formula(f'h_({L})')} "
                f"from {formula(f'G_({L})')}, on the side that gives its moment about {formula(f'G_({L})')} the "
                f"sense of {formula(f'C_(i {L})')})"))
    return out


# --------------------------------------------------------------------------------------- equilibrium


def _columns(p, link) -> tuple[list[str], list[str]]:
    """Each unknown's math symbol and whether it is a force ('F') or a couple ('M'), column order."""
    lab = p.label
    syms, dims = [], []
    for j in link.joints:
        if isinstance(j, Prismatic):
            pair = m(lab(j.guide) + lab(j.block))
            syms += [f"N_({pair})", f"M_({pair})"]
            dims += ["F", "M"]
        else:
            pair = m(lab(j.a) + lab(j.b))
            syms += [f"F_({pair} x)", f"F_({pair} y)"]
            dims += ["F", "F"]
    if link.driver.kind == "torque":
        syms.append("T")
        dims.append("M")
    else:
        syms.append("P")
        dims.append("F")
    return syms, dims


def _group_symbol(p, group: str) -> str:
    if group.startswith("inertia:"):
        return f"F_(i {m(p.label(group.split(':', 1)[1]))})"
    if group == "gravity":
        return "W"
    return m(group)


def equilibrium(p, sol) -> dict:
    """Each moving link's ΣFx, ΣFy and ΣM about its origin point: symbolic, with numbers, solved;
    and the assembled system A·x = b in display units.

    Rows and columns are the solver's own (`Solution.matrix`, `Solution.rhs`: A·x + B = 0), scaled
    to the problem's force and torque units, so every printed line is one row of the solved system.
    """
    link = sol.linkage
    nm = Names(p, link)
    fu, tu = p.units["force"], p.units["torque"]
    kf, kt = units.factor("N", fu), units.factor("N*m", tu)
    A, B = np.asarray(sol.matrix, float), np.asarray(sol.rhs, float)
    syms, dims = _columns(p, link)
    kcol = np.array([kf if d == "F" else kt for d in dims])
    x = []
    for j in link.joints:
        x += list(np.asarray(sol.total.joints[j.name], float))
    x.append(sol.total.driver)
    x = np.asarray(x) * kcol
    for d in ("F", "M"):  # an unknown that is a round-off zero prints as 0, not 8e-16
        cols = [c for c, dd in enumerate(dims) if dd == d]
        big = max((abs(x[c]) for c in cols), default=0.0)
        for c in cols:
            x[c] = 0.0 if abs(x[c]) <= 1e-12 * big else x[c]
    groups = list(sol.groups)
    bodies = list(link.bodies)
    krow = np.array([kf, kf, kt] * len(bodies))
    Ad = A * krow[:, None] / kcol[None, :]
    Bd = B * krow[:, None]
    b = -Bd.sum(axis=1)
    fscale = max(float(np.max(np.abs(Ad[:, :] * x[None, :]))), float(np.max(np.abs(Bd))) if Bd.size else 0.0, 1e-300)
    arm_u = next((L for L in (p.units["length"], "m", "mm", "cm", "in", "ft")
                  if abs(units.factor(f"{tu}/{fu}", L) - 1.0) < 1e-12), f"{tu}/{fu}")
    links = []
    heads = []
    for k, body in enumerate(bodies):
        origin = link.bodies[body].origin
        oname = nm.pt(nm.point_at(origin.pos()))
        lines = []
        for i, head in enumerate(("sum F_x", "sum F_y", f"sum M_({m(oname)})")):
            r = 3 * k + i
            heads.append(Typ(f"{formula(head)} ({text(p.label(body))})"))
            sym, numeric, solved = [], [], []
            for c, s in enumerate(syms):
                a = Ad[r, c]
                if abs(a * x[c]) <= 1e-12 * fscale and abs(a) <= 1e-12 * max(1.0, float(np.max(np.abs(Ad[r])))):
                    continue
                sym.append(_symbolic(p, link, nm, body, i, c, s, a, oname))
                numeric.append((a, s))
                solved.append(a * x[c])
            for g, grp in enumerate(groups):
                v = Bd[r, g]
                if abs(v) <= 1e-12 * fscale:
                    continue
                gs = _group_symbol(p, grp)
                if i < 2:
                    sym.append(f"+ {gs}_{'xy'[i]}" if "_" not in gs else f"+ {gs[:-1]} {'xy'[i]})")
                    numeric.append((v, ""))
                    solved.append(v)
                    continue
                couple = 0.0
                if grp.startswith("inertia:") and grp.split(":", 1)[1] == body:
                    couple = float(sol.states[body].inertia_couple) * kt
                moment = v - couple
                pure = abs(Bd[r - 1, g]) <= 1e-12 * fscale and abs(Bd[r - 2, g]) <= 1e-12 * fscale
                if abs(moment) > 1e-12 * fscale:
                    sym.append(f"+ {gs}" if pure else f"+ M_({m(oname)})({gs})")
                    numeric.append((moment, ""))
                    solved.append(moment)
                if couple:
                    sym.append(f"+ C_(i {nm.body(body)})")
                    numeric.append((couple, ""))
                    solved.append(couple)
            symtxt = " ".join(sym).strip()
            symtxt = symtxt[2:] if symtxt.startswith("+ ") else symtxt
            numtxt = _signed_coef(numeric)
            soltxt = _signed([(v, "") for v in solved])
            lines.append({"symbolic": formula(f"{head} = {symtxt or '0'} = 0"),
                          "numbers": formula(f"{numtxt} = 0"),
                          "solved": formula(f"{soltxt} = 0"),
                          "terms": [n(v) for v in solved]})
        links.append({"body": p.label(body), "name": body, "point": oname, "lines": lines})
    matrix = {
        "columns": [formula(s) for s in syms],
        "rows": [{"head": heads[r], "cells": [num(0.0 if abs(Ad[r, c]) <= 1e-12 * float(np.max(np.abs(Ad[r])))
                                                  else Ad[r, c], COEF_SIG) for c in range(len(syms))],
                  "b": num(_clean(b[r], fscale), SIG)} for r in range(len(heads))],
        "x": [{"symbol": formula(s), "value": num(_clean(x[c], fscale), SIG)} for c, s in enumerate(syms)],
        "units": f"force rows in {units.pretty(fu)}, moment rows in {units.pretty(tu)}; force unknowns in "
                 f"{units.pretty(fu)}, couples in {units.pretty(tu)} (moment arms in {units.pretty(arm_u)})",
    }
    return {"links": links, "matrix": matrix, "force_unit": fu, "torque_unit": tu}


def _symbolic(p, link, nm, body, row, c, s, a, oname) -> str:
    """The term of unknown column *c* in equation *row* of *body*, written with symbols."""
    k = c // 2
    sign = "+" if a > 0 else "-"
    if c == len(link.joints) * 2:  # the driver
        if link.driver.kind == "torque" or row < 2:
            return f"{sign} {s}" if row == 2 or link.driver.kind == "torque" else f"+ {s} hat(u)_{'xy'[row]}"
        return f"+ M_({m(oname)})(P)"
    j = link.joints[k]
    if isinstance(j, Prismatic):
        if c % 2:
            return f"{sign} {s}"
        if row < 2:
            return f"{'+' if body == j.block else '-'} {s} hat(n)_{'xy'[row]}"
        return f"+ M_({m(oname)})({'-' if body == j.guide else ''}{s} hat(n))"
    on_b = body == j.b
    if row < 2:
        return f"{'+' if on_b else '-'} {s}"
    P = nm.pt(nm.point_at(j.point.pos())) or j.name
    arm = m(oname + P)
    comp = "y" if c % 2 else "x"
    if comp == "y":
        return f"{'+' if on_b else '-'} x_({arm}) {s}"
    return f"{'-' if on_b else '+'} y_({arm}) {s}"


def _signed_coef(terms: list[tuple[float, str]]) -> str:
    """``1.5 F_x − 21.2 F_y + 139.4`` from (coefficient, symbol) terms; a coefficient ±1 is left out."""
    out = []
    for v, s in terms:
        mag = n(abs(v), COEF_SIG if s else SIG)
        if mag == "0":
            continue
        body = s if s and mag == "1" else (f"{mag} {s}" if s else mag)
        out.append(("−" if v < 0 else "+") + " " + body)
    text = " ".join(out) or "0"
    return text[2:] if text.startswith("+ ") else "−" + text[2:] if text.startswith("− ") else text


# ---------------------------------------------------------------------------------------- graphical


def construction(p, sol) -> list[dict]:
    """The graphical method in steps: for a superposition problem, one construction per part."""
    if len(sol.groups) > 1:
        return [{"part": _part(p, g), "steps": _construction(p, sol, r)} for g, r in sol.groups.items()]
    return [{"part": "", "steps": _construction(p, sol, sol.total)}]


def _construction(p, sol, group) -> list[Typ]:
    """The graphical method in steps, member by member (two-force members first)."""
    from gradekit.figures.key import POLY_SIZE, force_name, nice
    from gradekit.figures.sheet import driver_key

    link = sol.linkage
    nm = Names(p, link)
    fu = p.units["force"]
    members = {b: mb for b, mb in group.members.items() if b != GROUND}
    # two-force members first (they fix lines of action), then from the output back to the driver
    two_first = [b for b in members if members[b].kind == "two-force"]
    rest = [b for b in reversed(list(members)) if b not in two_first and b != link.driver.body]
    order = two_first + rest + [b for b in members if b == link.driver.body and b not in two_first]

    key = driver_key(SimpleNamespace(problem=p))

    def fname(f) -> str:  # as the free-body diagrams and polygons label it
        return str(text(force_name(p, link, f, key)))

    def at(f) -> str:
        name = nm.point_at(f.point)
        return f" at {text(nm.pt(name))}" if name else ""

    two = {b for b in order if members[b].kind == "two-force"}
    out = []
    for step, b in enumerate(order, 1):
        mb = members[b]
        L = text(p.label(b))  # names from the problem file: text, never markup
        fs = mb.forces
        span = float(np.max(mb.polygon.max(axis=0) - mb.polygon.min(axis=0))) if len(fs) else 0.0
        bar = ""
        if span > 0:
            per_pt = units.convert(span / POLY_SIZE, "N", fu)
            bar = (f" Force scale: the bar of {n(nice(POLY_SIZE / 3 * per_pt), 4)} {text(units.pretty(fu))} under "
                   "its polygon.")
        pins = [f for f in fs if f.kind in ("pin", "normal")]
        knowns = [f for f in fs if f.kind not in ("pin", "normal", "driver")]
        if mb.kind == "two-force":
            a, c = fs
            pa, pc = nm.point_at(a.point), nm.point_at(c.point)
            if pa and pc and pa != pc:
                line = text(f"{nm.pt(pa)}{nm.pt(pc)}")
            elif pa and any(f.kind == "normal" for f in fs):
                line = f"the normal to the slide through {text(nm.pt(pa))}"
            else:
                line = "the line joining their points"
            out.append(Typ(f"{step}. Link {L} is a two-force member: {fname(a)} and {fname(c)} are equal, opposite "
                           f"and act along {line}; so the line of action of each is known."))
        elif mb.kind == "three-force":
            kn = ", ".join(fname(f) + at(f) for f in knowns)
            dirs = [f for f in pins if _partner_two_force(link, f, two)]
            rest3 = [f for f in fs if f not in knowns and f not in dirs]
            k = mb.concurrency
            ku = p.units["length"]
            kk = units.factor("m", ku)
            if knowns and dirs and k is not None:
                out.append(Typ(
                    f"{step}. Link {L} is a three-force member. {kn} is known in full; the line of action of "
                    f"{', '.join(fname(f) for f in dirs)} is known (along its two-force member). These two lines meet "
                    f"at K = ({n(k[0] * kk, 4)}, {n(k[1] * kk, 4)}) {text(units.pretty(ku))}, so "
                    f"{', '.join(fname(f) + at(f) for f in rest3)} passes through K too. Draw {kn} to scale; through "
                    f"its ends draw lines parallel to the other two: where they cross closes the polygon and gives "
                    f"both magnitudes.{bar}"))
            else:
                out.append(Typ(
                    f"{step}. Link {L} is a three-force member{' (' + kn + ' known in full)' if kn else ''}; the "
                    f"lines of action of its unknown forces are not fixed by a two-force member, so its forces come "
                    f"from the equilibrium equations above (or from the links already solved); its polygon then "
                    f"closes as drawn.{bar}"))
        elif not fs and not mb.couples:
            out.append(Typ(f"{step}. Link {L} carries no force in this part."))
        elif mb.kind == "two-forces-and-couple" and knowns:
            a = knowns[0]
            c = next(f for f in fs if f is not a)
            out.append(Typ(f"{step}. Link {L}: two forces and a couple. {fname(a)}{at(a)} is known; {fname(c)} is "
                           f"equal, opposite and parallel to it, and the couple they form balances the remaining "
                           f"couple (their size times the distance between their lines of action).{bar}"))
        elif mb.kind == "two-forces-and-couple":
            a, c = fs
            out.append(Typ(f"{step}. Link {L}: two forces and a couple. {fname(a)} and {fname(c)} are equal, "
                           f"opposite and parallel; they form a couple that balances the applied couple, so their "
                           f"size is the couple divided by the distance between their lines of action.{bar}"))
        else:
            kn = ", ".join(fname(f) + at(f) for f in knowns) or "none"
            out.append(Typ(f"{step}. Link {L}: {len(fs)} forces{' and a couple' if mb.couples else ''} "
                           f"(known in full: {kn}). Add the known forces head to tail first; with the directions "
                           f"found from the links already solved, the polygon closes with the unknown ones; "
                           f"where more than two are unknown, its moment equation above gives one first.{bar}"))
    return out


def _partner_two_force(link, f, two) -> bool:
    j = next((j for j in link.joints if j.name == f.name), None)
    if j is None or isinstance(j, Prismatic):
        return False
    other = j.a if f.body == j.b else j.b
    return other in two


# ------------------------------------------------------------------------------------- superposition


def superposition(p, sol, driver_unit: str) -> list[Typ]:
    """Each part's driver and the sum that is the total."""
    if len(sol.groups) < 2:
        return []
    k = units.factor("N*m" if sol.linkage.driver.kind == "torque" else "N", driver_unit)
    sym = "T" if sol.linkage.driver.kind == "torque" else "P"
    parts = [(g, r.driver * k) for g, r in sol.groups.items()]
    big = max(abs(v) for _, v in parts)
    parts = [(g, 0.0 if abs(v) <= 1e-12 * big else v) for g, v in parts]
    names = " + ".join(f"{sym}_({m(_part(p, g))})" for g, _ in parts)
    values = _signed([(v, "") for _, v in parts], zeros=True)
    total = n(sol.total.driver * k)
    summed = formula(f"{sym} = {values} = {total}")
    return [formula(f"{sym} = {names}"), Typ(f"{summed} {text(units.pretty(driver_unit))}")]


def _part(p, group: str) -> str:
    if group.startswith("inertia:"):
        return f"inertia {p.label(group.split(':', 1)[1])}"
    return group
