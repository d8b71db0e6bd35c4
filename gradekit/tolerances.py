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

from gradekit import quantities, units
from gradekit.errors import GradekitError
from gradekit.keys import Tolerance

KINDS = ("angle", "force", "force-component", "torque", "kinematic", "length")
SECTION = "_kind_defaults"


def answer_kind(of: str, unit: str) -> str:
    """The kind of an answer: angle, torque, force, force-component, kinematic or length.

    The quantity table (`gradekit.quantities`) says it; where it leaves it to the unit (the driver,
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
    import yaml

    from gradekit.resources import resource_dir

    f = resource_dir("problem_bank") / "_tolerances.yaml"
    try:
        data = yaml.safe_load(f.read_text(encoding="utf-8")) or {}
        table = data[SECTION]
        out = {(m, k): from_row(r) for m, kinds in table.items() for k, r in kinds.items()}
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
        raise GradekitError(
            f"{f}: expected the generated tolerance table with its {SECTION} section "
            f"(python benchmarks/derive_tolerances.py), got {type(exc).__name__}: {exc}"
        ) from None
    for m in ("analytical", "graphical"):  # a kind no bank answer has yet: that of the other method, or the loosest
        for k in KINDS:
            if (m, k) not in out:
                other = [t for (mm, kk), t in out.items() if kk == k] or [
                    t for (mm, kk), t in out.items() if (kk == "angle") == (k == "angle")
                ]
                out[(m, k)] = max(other, key=lambda t: (t.abs, t.rel, t.floor))
    return out


def default(method: str, of: str, unit: str) -> Tolerance:
    """The measured default for an answer of *method* asking for *of* in *unit*."""
    return defaults()[(method, answer_kind(of, unit))]
