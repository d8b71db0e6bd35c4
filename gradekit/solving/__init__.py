"""The solving pipeline, from a problem and a student to their answer key.

sampling (a student's parameter values) → parameters (derived values, rounding) → assembly (problem and
values → linkage and loads, SI) → the numeric core (`gradekit.mechanics`) → answers (named results,
answer values) → keys (what a student must answer, within which tolerance; `tolerances`, `quantities`),
with the catalogued mistakes (`mistakes`) and error carried forward (`carry`); `pipeline` runs the
phases, `report` prints what `gradekit solve` shows.
"""
