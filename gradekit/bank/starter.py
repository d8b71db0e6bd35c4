"""Starter problems and per-kind documentation, generated from the mechanism registry.

`starter(kind)` is what ``gradekit bank new KIND`` prints: a commented problem file that validates
and solves as it stands (its geometry is the kind's registry example), for the author to edit.
`kinds_reference()` is docs/kinds.md: each kind's bodies, points, geometry, drivers and branch.
Neither names a kind: both read `gradekit.mechanics.mechanisms.KINDS`.
"""

from __future__ import annotations

import math

from gradekit.mechanics.mechanisms import KINDS, carriers


def _mm(kind: str, name: str, si: float) -> str:
    return f"{math.degrees(si):g}" if name in KINDS[kind].angles else f"{si * 1000:g}"


def _labels(kind: str) -> dict[str, str]:
    return {"ground": "1", **{b: str(i) for i, b in enumerate(KINDS[kind].bodies, start=2)}}


def starter(kind: str) -> str:
    """A commented starter problem for *kind* (YAML text)."""
    if kind not in KINDS:
        raise KeyError(kind)
    k = KINDS[kind]
    labels = _labels(kind)
    last = k.bodies[-1]
    on = carriers(kind)
    load_at = next((p for p, bs in reversed(on.items()) if last in bs and "ground" not in bs), k.points[-1])
    geo = ", ".join(f"{g}: {g}" for g in k.required)
    params = "\n".join(
        f"  {g}: {{value: {_mm(kind, g, k.example[g])}, unit: mm, symbol: {''.join(k.dimensions.get(g, (g,)))}, "
        f"description: {g.replace('_', ' ')}}}"
        for g in k.required
    )
    optional = ", ".join(
        f"{g}: {math.degrees(v) if g in k.angles else v * 1000:g}{' (deg)' if g in k.angles else ''}"
        for g, v in k.optional.items()
    )
    points = ", ".join(f"{p} (on {' and '.join(on[p])})" for p in k.points)
    first_pin = next(p for p, bs in on.items() if "ground" in bs)
    ground_body = next(b for b in on[first_pin] if b != "ground")
    return f"""\
# A starter {kind} problem: `gradekit bank new {kind}` (edit every line; see docs/authoring.md).
# {k.about}
# Points (use them in at:, between:, r[..], v[..], a[..]): {points}.
# Optional geometry (defaults): {optional or "none"}.
# branch: {k.branch}
id: my-{kind.replace("_", "-")}
title: "Force analysis of a {kind.replace("_", " ")}"     # printed on every sheet: no source values
source: {{document: "Textbook, edition", ref: "Example 0.0"}}  # printed: document and section only
method: analytical            # analytical | graphical (selects the measured default tolerances)
analysis: static              # static | dynamic (d'Alembert inertia of every body in mass:)
units: mm-N-s                 # SI | mm-N-s | in-lbf-s | ft-lbf-s, or a mapping per dimension
mechanism:
  type: {kind}
  labels: {{{", ".join(f"{b}: {l!r}" for b, l in labels.items()).replace("'", '"')}}}
  geometry: {{{geo}}}
  input: {{theta: theta}}      # add omega: (and alpha:) for a dynamic analysis or a damper
  # branch: open               # open (+1) | crossed (-1)
  # points: {{P: {{on: {last}, from: {load_at}, along: 20, perp: 0}}}}   # a point of your own
parameters:
{params}
  theta: {{value: 60, range: [50, 70], step: 1, unit: deg, symbol: "θ2", description: crank angle}}
  F: {{value: 100, range: [50, 150], step: 1, unit: N, symbol: F, description: the load}}
loads:
  - {{name: F, body: {last}, at: {load_at}, magnitude: F, angle: 180}}
statement: |
  The {kind.replace("_", " ")} in the figure has {", ".join(f"{''.join(k.dimensions.get(g, (g,)))} = {{{{ {g} }}}}"
                                                         for g in k.required)}.
  The crank is at θ2 = {{{{ theta }}}}. A force F = {{{{ F }}}} acts at {load_at} along −x.
  Find the driving torque T on the crank and the force F12 of the frame on the crank.
answers:
  - {{key: T, of: driver, unit: N*m, description: driving torque on the crank, sign: counterclockwise positive}}
  - {{key: F12, of: "F[1,{labels[ground_body]}].mag", unit: N,
     description: force of the frame on the crank at {first_pin}}}
# published:                   # the numbers the source prints, checked against the solver
#   answers:
#     T: {{value: 1.234, unit: N*m, rel: 0.0005}}   # rel: half a unit of the last printed digit
"""


def kinds_reference() -> str:
    """docs/kinds.md: every mechanism kind as the registry declares it."""
    out = [
        "# Mechanism kinds",
        "",
        "Generated from the registry (`gradekit/mechanics/mechanisms.py` `KINDS`) by",
        "`gradekit.bank.starter.kinds_reference()`; a test keeps this file equal to it. Lengths in mm and",
        "angles in degrees here; `gradekit bank new KIND` prints a starter problem for each kind.",
        "",
    ]
    for name, k in KINDS.items():
        on = carriers(name)
        figure = f"![{name}: the starter's mechanism with its default labels](kinds/{name}.svg)"
        out += [f"## `{name}`", "", k.about, "", figure, ""]
        out += [f"- **bodies** (equilibrium order): {', '.join(k.bodies)} (besides `ground`)"]
        out += ["- **points** (and the bodies each is fixed on): "
                + "; ".join(f"`{p}` ({', '.join(on[p])})" for p in k.points)]
        out += [f"- **geometry, required**: {', '.join(f'`{g}`' for g in k.required)}"]
        opt = ", ".join(
            f"`{g}` = {math.degrees(v) if g in k.angles else v * 1000:g}{'°' if g in k.angles else ''}"
            for g, v in k.optional.items()
        )
        out += [f"- **geometry, optional** (default): {opt or 'none'}"]
        out += [f"- **angle parameters**: {', '.join(f'`{a}`' for a in k.angles) or 'none'}"]
        out += [f"- **drivers**: {', '.join(f'`{d}`' for d in k.drivers)} (the first is the default)"]
        out += [f"- **branch**: {k.branch}"]
        out += ["- **example geometry** (the starter's): "
                + ", ".join(f"{g} = {_mm(name, g, v)}" for g, v in k.example.items()), ""]
    return "\n".join(out)
