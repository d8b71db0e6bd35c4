"""Default answer tolerances per method and answer kind, read from the measurement.

The defaults are the ``_kind_defaults`` section of ``problem_bank/_tolerances.yaml``, written by
``python benchmarks/derive_tolerances.py`` from the honest-student study (benchmarks/RESULTS.md):
per (method, answer kind), the narrowest band whose 95 % upper bound of the honest false-reject
rate is below 0.1 % on every answer of that kind in the bank. Nothing here is copied by hand.
``floor`` is a fraction of the variant's scale (its largest answer of the same dimension), so
small components are judged by the accuracy of the whole construction; angles wrap at 360°.
"""

from __future__ import annotations

import functools
import math

from gradekit import units
from gradekit.errors import GradekitError
from gradekit.solving import quantities
from gradekit.solving.keys import Tolerance

ANSWER_KINDS = ("angle", "force", "force-component", "torque", "kinematic", "length")
SECTION = "_kind_defaults"


def answer_kind(of: str, unit: str) -> str:
    """The kind of an answer: angle, torque, force, force-component, kinematic or length.

    The quantity table (`gradekit.solving.quantities`) says it; where it leaves it to the unit (the driver,
    a parameter, a derived expression), the unit does.
    """
    asked = quantities.parse(of)
    if asked is not None and asked.kind:
        return asked.kind
    si = units.si_unit(unit)
    if si == units.si_unit("deg"):
        return "angle"
    if si == units.si_unit("N*m"):
        return "torque"
    if si == units.si_unit("N"):
        return "force-component" if of.endswith((".x", ".y")) or of.startswith("M[") else "force"
    if si == units.si_unit("m"):
        return "length"
    return "kinematic"


def from_row(row: dict) -> Tolerance:
    """A band of the generated table: ``{deg}`` for angles, else ``{rel, floor}`` and an optional
    ``abs`` (in the answer's unit)."""
    if "deg" in row:
        return Tolerance("relative", 0.0, float(row["deg"]), period=360.0)
    return Tolerance("relative", float(row["rel"]), float(row.get("abs", 0.0)), floor=float(row.get("floor", 0.0)))


def to_row(tol: Tolerance) -> dict:
    """`from_row`'s inverse: ``{deg}`` for an angle band, else ``{rel, floor}`` (and ``abs`` when set)."""
    if tol.period:
        return {"deg": tol.abs}
    return {"rel": tol.rel, "floor": tol.floor, **({"abs": tol.abs} if tol.abs else {})}


@functools.lru_cache(maxsize=1)
def defaults() -> dict[tuple[str, str], Tolerance]:
    """``(method, kind) -> Tolerance`` from the bank's generated ``_tolerances.yaml``."""
    from gradekit.bank.yamlfile import safe_data
    from gradekit.resources import resource_dir

    f = resource_dir("problem_bank") / "_tolerances.yaml"
    try:
        data = safe_data(f.read_text(encoding="utf-8"), f, "the generated tolerance table") or {}
        table = data[SECTION]
        out = {(m, k): from_row(r) for m, kinds in table.items() for k, r in kinds.items()}
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise GradekitError(
            f"{f}: expected the generated tolerance table with its {SECTION} section "
            f"(python benchmarks/derive_tolerances.py), got {type(exc).__name__}: {exc}"
        ) from None
    for m in ("analytical", "graphical"):  # a kind no bank answer has yet: that of the other method, or the loosest
        for k in ANSWER_KINDS:
            if (m, k) not in out:
                other = [t for (mm, kk), t in out.items() if kk == k] or [
                    t for (mm, kk), t in out.items() if (kk == "angle") == (k == "angle")
                ]
                out[(m, k)] = max(other, key=lambda t: (t.abs, t.rel, t.floor))
    return out


def default(method: str, of: str, unit: str) -> Tolerance:
    """The measured default for an answer of *method* asking for *of* in *unit*."""
    return defaults()[(method, answer_kind(of, unit))]


# --- discrimination: what a band lets through -------------------------------------------------

OFF_FAR = (0.10, 5.0)  # an answer 10 % off (a direction 5° off) must lose its credit (issue 25)
OFF_NEAR = (0.05, 2.0)  # reported beside it: 5 % off (a direction 2° off)
DISCRIMINATION_MIN = 0.95  # share of variants in which an answer OFF_FAR off (or a catalogued mistake) is rejected
FALSE_REJECT_MAX = 0.001  # the 95 % upper bound of the honest false-reject rate must be below this

# The accuracy of graphical work the bands assume (benchmarks/tolerance_study.py's drawing model), printed on
# the sheets of graphical problems: lengths laid off and read to READ_MM on paper, directions to READ_DEG, every
# polygon drawn with its largest vector POLYGON_MM long (the 1-2-5 scale that fits).
READ_MM = 0.5
READ_DEG = 0.5
POLYGON_MM = (60.0, 150.0)
# A graphical torque is the pin force's component across the crank, read off the polygon, times the crank
# radius: its reading error is READ_MM at the polygon's scale plus the pin force times READ_DEG. Where the
# component is under ARM_MIN of the polygon's largest force, that error alone exceeds a third of the 10 % a
# band must reject (the rest is the construction's: points and lines of action taken off the sheet): a force
# polygon whose sides are nearly parallel to the crank. Such a variant is not drawn.
ARM_MIN = (READ_MM / POLYGON_MM[0] + math.radians(READ_DEG)) / (OFF_FAR[0] / 3)


def is_direction(unit: str) -> bool:
    """An answer in degrees is a direction (an angle wrapped at 360°): it is moved by degrees, not by a share."""
    return units.si_unit(unit) == units.si_unit("deg")


def off_by(values, unit: str, off: tuple[float, float]):
    """*values* moved by ``off`` = (relative share, degrees): a direction by the degrees, anything else by the share."""
    import numpy as np

    v = np.asarray(values, float)
    return v + off[1] if is_direction(unit) else v * (1.0 + off[0])


def accepted_off(tol: Tolerance, values, scales, unit: str, off: tuple[float, float]):
    """Per variant: would an answer ``off`` away from its key (`off_by`) still earn full credit under *tol*?"""
    return tol.accepts_many(off_by(values, unit, off), values, scales)


def mistake_size(tol: Tolerance, got, values, unit: str):
    """How far a mistake moves each answer: degrees for a direction, else a share of the answer."""
    import numpy as np

    d = np.abs(tol.difference(np.asarray(got, float), np.asarray(values, float)))
    return d if is_direction(unit) else d / np.maximum(np.abs(np.asarray(values, float)), 1e-300)


def mistake_gradable(median_size: float, unit: str) -> bool:
    """A mistake a band must catch: one that moves the answer (in the median variant) by more than the
    10 % (5°) an answer may be off and still lose its credit. A smaller one is no mistake a grade can see
    apart from honest work, and is reported with its size instead."""
    return median_size > (OFF_FAR[1] if is_direction(unit) else OFF_FAR[0])


def band_text(tol: Tolerance) -> str:
    """A band as a report prints it: ``±2 %, floor 3 % of scale, at least ±0.5`` or ``±1.5°``."""
    if tol.period:
        return f"±{tol.abs:g}°"
    parts = [f"±{100 * tol.rel:g} %"] if tol.rel else []
    if tol.floor:
        parts.append(f"floor {100 * tol.floor:g} % of scale")
    if tol.abs:
        parts.append(f"at least ±{tol.abs:g}")
    return ", ".join(parts) or "0"
