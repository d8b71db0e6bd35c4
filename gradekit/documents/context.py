"""The one place a document's template context is built: a student's sheet, or the worked key."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from gradekit import units
from gradekit.assignment import Assignment, Item, keys_for
from gradekit.documents import steps
from gradekit.documents.typeset import (
    Typ,
    cell,
    formula,
    num,
    paragraph_texts,
    paragraphs,
    string,
    table,
    text,
    unit,
)
from gradekit.mechanics.model import GROUND, Prismatic
from gradekit.roster import Student
from gradekit.solving.pipeline import CaseResult, Result
from gradekit.solving.report import display_unit
from gradekit.solving.sampling import Variant
from gradekit.statement import render_statement


@dataclass(frozen=True)
class Picture:
    """A figure written to the build folder: its path relative to the Typst root and how to place it."""

    path: str
    caption: str
    true_scale: bool = False
    scale_text: str = ""
    wide: bool = False  # a true-scale drawing wider than the text: placed on a landscape page
    alt: str = ""  # the text alternative, written from the model as it was drawn
    svg: bytes = b""  # the drawing itself (a sheet's HTML version inlines it)


@dataclass(frozen=True)
class Solved:
    """One item of the assignment solved for one student, with its pictures."""

    item: Item
    variant: Variant
    scenes: tuple[Picture, ...]
    key_pictures: tuple[Picture, ...] = ()


def build_context(asg: Assignment, student: Student, solved: list[Solved], *, key: bool) -> dict:
    """The template context of *student*'s assignment sheet, or of their worked key when *key*.

    Answer values enter the context only when *key* is set: the sheet's template cannot print
    what it is never given.
    """
    problems = []
    number = 0  # the sheet's figure numbers, in the order the sheet template places the figures
    for s in solved:
        res = s.variant.result
        entries = keys_for(asg, s.item, student.student_id, s.variant, with_mistakes=False)
        scenes = _scenes(res, s.scenes, number)
        number += len(scenes)
        p = {
            "label": s.item.label,
            "title": res.problem.title,
            # the course document's example or figure number is the instructor's: a student's
            # sheet points to their own values, not to a published solution
            "source": _source(res.problem.source) if key else "",
            "points": num(s.item.points, 4),
            "method": res.problem.method,
            "analysis": res.problem.analysis,
            "statement": paragraphs(_statement(res, scenes, key=key)),
            "statement_paragraphs": paragraph_texts(_statement(res, scenes, key=key)),
            "scenes": scenes,
            "wide": any(f["wide"] for f in scenes),
            "asked": [{"key": e.key, "description": e.description, "unit": e.unit,
                       "unit_shown": units.pretty(e.unit),
                       "sign": e.sign_convention, "points": num(e.points, 4)} for e in entries],
        }
        if not key:
            p["asked_table"] = table(
                [[Typ("Key"), Typ("Quantity"), Typ("Unit"), Typ("Sign convention"), Typ("Points")]]
                + [[_raw(a["key"]), cell(a["description"]), unit(a["unit"]), cell(a["sign"]), a["points"]]
                   for a in p["asked"]],
                ["auto", "1fr", "auto", "auto", "auto"], ["left", "left", "left", "left", "right"])
        if key:
            p.update(_worked(res, entries, s.key_pictures))
        problems.append(p)
    total = sum(s.item.points for s in solved)
    spelled = {a["unit"]: units.pretty(a["unit"]) for pr in problems for a in pr["asked"] if a["unit"]}
    return {
        "course": asg.course,
        "term": asg.term,
        "title": asg.title,
        "due": asg.due,
        "instructions": paragraphs(asg.instructions) if asg.instructions.strip() else Typ(""),
        "submission": paragraphs(asg.submission) if asg.submission.strip() else Typ(""),
        # the same texts as plain paragraphs, for the sheet's HTML version
        "instructions_paragraphs": paragraph_texts(asg.instructions),
        "submission_paragraphs": paragraph_texts(asg.submission),
        "student": {"id": student.student_id, "name": student.display, "section": student.section},
        "total_points": num(total, 4),
        "problems": problems,
        "key": key,
        # units the sheet prints differently from how answers.csv spells them: N·m is typed N*m
        "unit_spellings": [{"sheet": Typ(text(s)), "csv": u} for u, s in spelled.items() if s != u],
    }


def _raw(key: str) -> Typ:
    return Typ(f"#raw({string(key)})")


def _source(src: dict[str, str]) -> str:
    return ", ".join(v for v in (src.get("document", ""), src.get("ref", "")) if v)


def _scenes(res: Result, pictures: tuple[Picture, ...], before: int) -> list[dict]:
    """The sheet's figures of one problem, numbered after the *before* figures ahead of them.

    A true-scale figure states the scale it is actually printed at (`printed_scale`: the
    problem's scale, or 1:2, 1:5 ... when that would not fit a page). When one figure of the
    problem needs a landscape page, all of them go there, so they stay in case order.
    """
    from gradekit.figures.sheet import printed_scale, ratio_text

    cases = [c.name for c in res.cases] if len(res.cases) > 1 else [None]
    wide = any(f.wide for f in pictures)
    out = []
    for i, f in enumerate(pictures):
        scale = ""
        if f.true_scale:
            k = printed_scale(res, cases[i] if i < len(cases) else None)
            scale = f"Drawn to scale {ratio_text(k)}: print at 100 % (no fit to page)." if k else f.scale_text
        out.append({"path": f.path, "caption": f.caption, "alt": f.alt, "svg": f.svg,
                    "true_scale": f.true_scale, "scale_text": scale,
                    "scale": ratio_text(k) if f.true_scale and k else "", "wide": wide,
                    "number": before + i + 1})
    return out


_FIGURE_WORDS = re.compile(r"\b[Tt]he figures?\b")


def _statement(res: Result, scenes: list[dict], *, key: bool) -> str:
    """The student's statement; "the figure(s)" becomes the sheet's own figure number(s).

    A figure printed at a reduced scale is named with its scale in a closing sentence.
    """
    text = render_statement(res.problem, res.values)
    if not scenes:
        return text
    nums = [f["number"] for f in scenes]
    if len(nums) == 1:
        ref = f"Figure {nums[0]}"
    elif len(nums) == 2:
        ref = f"Figures {nums[0]} and {nums[1]}"
    else:
        ref = f"Figures {nums[0]}–{nums[-1]}"
    if key:
        ref += " of the sheet"
    text, n = _FIGURE_WORDS.subn(ref, text)
    scales = list(dict.fromkeys(f["scale"] for f in scenes if f["scale"]))
    if len(scales) == 1:
        verb = "is" if len(nums) == 1 else "are"
        text += f"\n\n{ref} {verb} drawn to scale {scales[0]} (print at 100 %, no fit to page)."
    elif scales:
        text += "\n\n" + "; ".join(f"Figure {f['number']} is drawn to scale {f['scale']}"
                                     for f in scenes if f["scale"]) + " (print at 100 %, no fit to page)."
    elif not n:
        text += f"\n\nSee {ref}."
    return text


def _worked(res: Result, entries, key_pictures) -> dict:
    p = res.problem
    given = []
    for name, value in res.values.items():
        par = p.parameters.get(name)
        if par is None:
            continue
        given.append({"symbol": par.symbol or name, "description": par.description,
                      "value": quantity(value, par.unit, 6), "derived": bool(par.expr)})
    cases = [case_context(res, c) for c in res.cases]
    scale: dict[str, float] = {}  # values below the answer's scale × 1e-12 are a zero's round-off
    for e in entries:
        scale[e.unit] = max(scale.get(e.unit, 0.0), abs(e.value))
    for a in res.answers:
        u = a.unit
        scale[u] = max(scale.get(u, 0.0), abs(units.convert(a.scale, units.si_unit(u), u)))
    answers = [{"key": e.key, "description": e.description,
                "value": num(0.0 if abs(e.value) <= 1e-12 * scale[e.unit] else e.value, 5), "unit": e.unit,
                "sign": e.sign_convention, "points": num(e.points, 4),
                # an answer no band can grade (the bank's hand_check) is marked for the instructor to check
                "tolerance": "checked by hand" if e.hand_check else e.tolerance.describe()}
               for e in entries]
    given_table = table(
        [[Typ("Symbol"), Typ("Description"), Typ("Value")]]
        + [[cell(g["symbol"]), cell(g["description"], Typ(" _(derived)_" if g["derived"] else "")), g["value"]]
           for g in given],
        ["auto", "1fr", "auto"], ["left", "left", "right"])
    answers_table = table(
        [[Typ("Key"), Typ("Quantity"), Typ("Value"), Typ("Tolerance"), Typ("Points")]]
        + [[_raw(a["key"]), cell(a["description"], Typ(f" #text(8pt)[({text(a['sign'])})]" if a["sign"] else "")),
            cell(Typ(f"*{a['value']}* "), unit(a["unit"])), cell(a["tolerance"]), a["points"]] for a in answers],
        ["auto", "1fr", "auto", "auto", "auto"], ["left", "left", "right", "left", "right"])
    return {
        "given": given,
        "given_table": given_table,
        "cases": cases,
        "key_pictures": key_pictures,
        "answers": answers,
        "answers_table": answers_table,
        "checks": {"residual": sci(res.virtual_work_residual), "condition": sci(res.condition_number),
                   "transmission": num(res.transmission_angle, 4)},
    }


def sci(x: float) -> Typ:
    """A small or large number as ``1.2 × 10⁻¹²`` (Typst math)."""
    if x == 0 or not math.isfinite(x):
        return num(x) if math.isfinite(x) else text(str(x))
    e = int(math.floor(math.log10(abs(x))))
    if -3 <= e <= 4:
        return num(x, 3)
    m = x / 10.0**e
    return formula(f"{num(m, 3)} times 10^({e})")


def quantity(value: float, unit: str, sig: int = 5) -> Typ:
    """``12.3 N·mm`` (or ``45°``) as markup: the number through `num`, the unit escaped."""
    pretty = units.pretty(unit)
    if not pretty:
        return num(value, sig)
    return Typ(f"{num(value, sig)}{'' if pretty == '°' else ' '}{text(pretty)}")


def _shown(p, value: float, si: str) -> tuple[float, str]:
    du = display_unit(p, si)
    return (units.convert(value, si, du) if du != si else value), du


def case_context(res: Result, case: CaseResult) -> dict:
    """Kinematics, inertia, equations, solved forces and superposition of one case (position)."""
    p = res.problem
    sol = case.solution
    link = sol.linkage
    lab = p.label
    r = case.results
    dynamic = p.analysis == "dynamic"

    biggest: dict[str, float] = {}
    for v, u in r.values():
        biggest[u] = max(biggest.get(u, 0.0), abs(v))

    def q(key: str, sig: int = 5) -> Typ:
        v, u = r[key]
        if u != "deg" and abs(v) <= 1e-12 * biggest.get(u, 0.0):
            v = 0.0  # round-off of a zero, not a value (no −0.0000000000000000069 N·m)
        return quantity(*_shown(p, v, u), sig)

    bodies = [b for b in link.bodies if b != GROUND]
    kin, inertia = [], []
    if dynamic:
        for b in bodies:
            L = lab(b)
            kin.append({"body": L, "theta": q(f"theta[{L}]"), "omega": q(f"omega[{L}]"),
                        "alpha": q(f"alpha[{L}]"), "aG": q(f"aG[{L}].mag"), "aG_dir": q(f"aG[{L}].angle"),
                        "aGx": q(f"aG[{L}].x"), "aGy": q(f"aG[{L}].y")})
            st = sol.states[b]
            m_unit = p.units.get("mass", "kg")
            i_unit = p.units.get("inertia", "kg*m**2")
            inertia.append({"body": L, "m": quantity(units.convert(st.mass, "kg", m_unit), m_unit),
                            "I": quantity(units.convert(st.inertia, "kg*m**2", i_unit), i_unit),
                            "Fi": q(f"Fi[{L}].mag"), "Fi_dir": q(f"Fi[{L}].angle"),
                            "Ci": q(f"Ci[{L}]"), "h": q(f"h[{L}]")})
    forces = []
    for j in link.joints:
        if isinstance(j, Prismatic):
            a, b = j.guide, j.block
        else:
            a, b = j.a, j.b
        stem = f"F[{lab(a)},{lab(b)}]"
        row = {"name": _joint_name(p, link, j), "symbol": formula(f"F_({_m(lab(a) + lab(b))})"),
               "x": q(stem + ".x"), "y": q(stem + ".y"), "mag": q(stem + ".mag"), "angle": q(stem + ".angle")}
        if isinstance(j, Prismatic):
            row["couple"] = q(f"M[{lab(a)},{lab(b)}]")
        forces.append(row)
    drv_sym = "T" if link.driver.kind == "torque" else "P"
    driver = {"symbol": Typ(drv_sym), "value": q("driver")}
    groups = []
    if len(sol.groups) > 1:
        for g in sol.groups:
            gl = _group_label(p, g)
            groups.append({"name": gl, "driver": q(f"driver@{gl}"),
                           "forces": [q(f"{row_stem(lab, j)}@{gl}.mag") for j in link.joints]})
        groups.append({"name": "total", "driver": q("driver"),
                       "forces": [q(f"{row_stem(lab, j)}.mag") for j in link.joints]})
    group_columns = [formula(f"F_({_m(_pair(lab, j))})") for j in link.joints]
    forces_table = table(
        [[Typ("Joint"), Typ("Force"), formula("x"), formula("y"), Typ("Magnitude"), Typ("Angle")]]
        + [[cell(f["name"]), f["symbol"], f["x"], f["y"], f["mag"], f["angle"]] for f in forces],
        ["auto"] * 6, ["right"] * 6)
    groups_table = table(
        [[Typ("Part"), formula(driver["symbol"]), *group_columns]]
        + [[cell(g["name"]), g["driver"], *g["forces"]] for g in groups],
        ["auto"] * (2 + len(group_columns)), ["right"] * (2 + len(group_columns))) if groups else None
    st = _steps(res, case, display_unit(p, "N*m" if link.driver.kind == "torque" else "N"))
    if st["matrix"] is not None:
        mx = st["matrix"]
        n = len(mx["columns"]) + 2
        st["matrix"] = mx | {"size": Typ(f"{6.0 if n > 13 else 7.5:g}pt"), "table": table(
            [[Typ(""), *mx["columns"], formula("b")]] + [[r["head"], *r["cells"], r["b"]] for r in mx["rows"]],
            ["auto"] * n, ["right"] * n, inset=(2.0, 2.0))}
    return {
        "name": case.name or "",
        "kinematics": kin,
        "inertia": inertia,
        "steps": st,
        "force_unit": p.units["force"],
        "torque_unit": p.units["torque"],
        "length_unit": p.units["length"],
        "forces": forces,
        "forces_table": forces_table,
        "driver": driver,
        "groups": groups,
        "group_columns": group_columns,
        "groups_table": groups_table,
        "vw_driver": quantity(*_shown(p, sol.virtual_work_driver, r["driver"][1])),
    }


def _joint_name(p, link, j) -> str:
    """A joint as the sheet names it: its point's printed name (O, B, C), a slider's 'slide at C'."""
    name = p.point(link.point_at(j.point.pos()) or j.name)
    return f"slide at {name}" if isinstance(j, Prismatic) else name


def row_stem(lab, j) -> str:
    a, b = (j.guide, j.block) if isinstance(j, Prismatic) else (j.a, j.b)
    return f"F[{lab(a)},{lab(b)}]"


def _pair(lab, j) -> str:
    a, b = (j.guide, j.block) if isinstance(j, Prismatic) else (j.a, j.b)
    return lab(a) + lab(b)


def _group_label(p, group: str) -> str:
    if group.startswith("inertia:"):
        return f"inertia[{p.label(group.split(':', 1)[1])}]"
    return group


_m = steps.m  # text inside Typst math, quoted


def _steps(res: Result, case: CaseResult, driver_unit: str) -> dict:
    """The route of one case: kinematics, inertia, equilibrium, the system or the construction, the sum.

    Only what the problem needs: velocities and accelerations for inertia or when asked, inertia for
    a dynamic problem, the assembled system for an analytical one, the construction for a graphical one.
    """
    p = res.problem
    sol = case.solution
    eq = steps.equilibrium(p, sol)
    return {
        "kinematics": steps.kinematics(p, sol),
        "inertia": steps.inertia(p, sol) if p.analysis == "dynamic" else [],
        "equilibrium": eq["links"],
        "matrix": eq["matrix"] if p.method == "analytical" else None,
        "construction": steps.construction(p, sol) if p.method == "graphical" else [],
        "superposition": steps.superposition(p, sol, driver_unit),
    }
