"""Default answer tolerances per method and answer kind, chosen from measurement.

The numbers come from `gradekit.tolerance_study` (``python benchmarks/run.py``, tables in
benchmarks/RESULTS.md): honest students are simulated on every bank problem over many variants,
and each default is the tightest band rejecting fewer than 0.1 % of honest answers. Honest work
means four significant figures carried through (what every sheet instructs) and, for graphical
problems, also a drawing at the printed scale read to ±0.5 mm and ±0.5°. ``floor`` is a fraction
of the variant's scale (its largest answer of the same dimension), so small components are
judged by the accuracy of the whole construction.
"""

from __future__ import annotations

from gradekit import units
from gradekit.keys import Tolerance

KINDS = ("angle", "force", "force-component", "torque", "kinematic", "length")


def answer_kind(of: str, unit: str) -> str:
    """The kind of an answer: angle, torque, force, force-component, kinematic or length."""
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


# (method, kind) -> default, for answers the per-answer table (problem_bank/_tolerances.yaml) does not
# cover yet. Measured by `python benchmarks/derive_tolerances.py` over the whole bank (21 problems,
# 40 variants x 30 simulated students per model), pooled per kind: honest false-reject / worst
# mistake detection. The worst detections are physics: a mistake smaller than honest error.
DEFAULTS: dict[tuple[str, str], Tolerance] = {
    ("analytical", "angle"): Tolerance("relative", 0.0, 1.5, period=360.0),  # 0.00 % / 100 %
    ("analytical", "force"): Tolerance("relative", 0.025),  # 0.04 % / 77.1 % (inertia torque left out)
    ("analytical", "force-component"): Tolerance("relative", 0.03, floor=0.03),  # 0.07 % / 41.7 % (gravity)
    ("analytical", "kinematic"): Tolerance("relative", 0.001, floor=0.03),  # 0.08 % / 99.3 %
    ("analytical", "length"): Tolerance("relative", 0.0075, floor=0.03),  # 0.10 % / 100 %
    ("analytical", "torque"): Tolerance("relative", 0.015, floor=0.1),  # 0.09 % / 30.0 % (gravity)
    ("graphical", "angle"): Tolerance("relative", 0.0, 5.0, period=360.0),  # 0.23 % (loosest tried) / 51.7 %
    ("graphical", "force"): Tolerance("relative", 0.1, floor=0.03),  # 0.07 % / 71.2 %
    ("graphical", "force-component"): Tolerance("relative", 0.1, floor=0.03),  # as force (none in the bank)
    ("graphical", "kinematic"): Tolerance("relative", 0.1),  # 0.06 % / 100 %
    ("graphical", "length"): Tolerance("relative", 0.1),  # 0.06 % / 100 %
    ("graphical", "torque"): Tolerance("relative", 0.1, floor=0.1),  # 0.10 % / 96.2 %
}


def default(method: str, of: str, unit: str) -> Tolerance:
    """The measured default for an answer of *method* asking for *of* in *unit*."""
    return DEFAULTS[(method, answer_kind(of, unit))]
