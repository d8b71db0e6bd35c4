"""The Python API: what the commands do, for notebooks and scripts (the CLI is a thin layer over it).

    import gradekit
    p = gradekit.load_problem("ch5-ex5-3")              # bank id or YAML path
    v = gradekit.sample(p, seed=123)                     # or student="1001", assignment="hw5.yaml"
    r = gradekit.solve(v)                                # r.answers["T"].value, .unit; r.checks
    vs = gradekit.sample_many(p, seeds=range(10_000))    # batched
    rs = gradekit.solve_many(vs)                         # rs.answers["T"]: an array (answer unit); rs.ok
    turn = gradekit.solve_many(p, {"phi1": numpy.arange(0.0, 360.0)})  # a crank turn in one batch
    fig = gradekit.figure(v, "scene")                    # a matplotlib Figure

Every function raises `gradekit.errors.GradekitError` (with file, line and field) for data a user
can fix. Nothing here imports matplotlib, typst or click until a figure, a document or a command
needs it, and importing gradekit never changes matplotlib's backend.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gradekit.bank.model import Problem
    from gradekit.solving.pipeline import Result, ResultBatch
    from gradekit.solving.sampling import Variant, VariantBatch


def load_problem(spec: str | Path, bank: str | Path | None = None) -> Problem:
    """A problem of the bank by id (``"ch5-ex5-3"``), or a problem YAML file by path."""
    from gradekit.bank.registry import resolve

    return resolve(str(spec), bank)


def _problem(p: Problem | str | Path) -> Problem:
    return p if hasattr(p, "parameters") else load_problem(p)


def sample(
    problem: Problem | str,
    *,
    seed: int | None = None,
    student: str | None = None,
    assignment: str | Path | None = None,
    manifest: str | Path | None = None,
    course: str = "",
    salt: str = "",
    redraw: int = 0,
) -> Variant:
    """One variant: from *seed*, a *student*'s (of *assignment*: its course, salt and re-draws,
    from *manifest* when given), or the published values when neither is given."""
    p = _problem(problem)
    if assignment is not None:
        if student is None:
            from gradekit.errors import GradekitError

            raise GradekitError("expected a student with an assignment, got none", path=str(assignment))
        from gradekit.assignment import sheet_variant

        return sheet_variant(assignment, p.id, student, manifest)
    from gradekit.solving.sampling import variant

    return variant(p, course=course, salt=salt, student=student, seed=seed, redraw=redraw)


def sample_many(
    problem: Problem | str,
    seeds: Iterable[int] | None = None,
    *,
    students: list[str] | None = None,
    course: str = "",
    salt: str = "",
) -> VariantBatch:
    """One variant per seed (or per student of *course* and *salt*), drawn and solved in batches.

    A seed with no acceptable draw is not an error: ``ok[i]`` is False and ``reason(i)`` says why.
    """
    from gradekit.solving.sampling import sample_many as draw

    p = _problem(problem)
    if seeds is None and students is None:
        from gradekit.errors import GradekitError

        raise GradekitError("expected seeds or students, got neither")
    return draw(p, None if seeds is None else list(seeds), course=course, salt=salt, students=students)


def solve(variant: Variant | Problem | str, values: dict[str, float] | None = None) -> Result:
    """A variant's solution (made once, when it was drawn), or a problem solved at *values*."""
    if hasattr(variant, "result"):
        return variant.result
    from gradekit.solving.pipeline import published_values, solve_problem

    p = _problem(variant)
    return solve_problem(p, {**published_values(p), **_known(p, values)})


def solve_many(variants: VariantBatch | Problem | str, values: dict | None = None) -> VariantBatch | ResultBatch:
    """Many solutions: those of a `VariantBatch` (already solved while drawing: nothing is solved
    twice), or a problem solved for arrays of *values* in one batch (e.g. a crank angle over a turn).

    Either way ``.answers[key]`` is an array in the answer's unit and ``.ok`` masks refused variants.
    """
    if hasattr(variants, "rows"):
        return variants
    import numpy as np

    from gradekit.solving.pipeline import published_values
    from gradekit.solving.pipeline import solve_many as batch

    p = _problem(variants)
    vals = {**published_values(p), **_known(p, values)}
    n = max((np.size(v) for v in vals.values()), default=1)
    return batch(p, vals, n)


def _known(p: Problem, values: dict | None) -> dict:
    """*values*, refused when one is not a parameter of *p* (a misspelt name would otherwise leave the
    published value in place and every answer the same, without a word)."""
    unknown = [name for name in values or {} if name not in p.parameters]
    if unknown:
        from gradekit.errors import GradekitError

        raise GradekitError(
            f"expected values of {p.id}'s parameters ({', '.join(p.parameters)}), got {', '.join(map(repr, unknown))}",
            path=p.path or None,
        )
    return dict(values or {})


def figure(variant: Variant | Result, name: str = "scene", case: str | None = None):
    """A matplotlib Figure of a variant: ``"scene"`` (the sheet's figure), ``"true-scale"``, or a key
    figure by its name (`figure_names`). The caller saves or shows it."""
    from gradekit import figures

    result = variant.result if hasattr(variant, "result") else variant
    if name in ("scene", "true-scale"):
        return figures.scene(result, case, true_scale=name == "true-scale")
    from gradekit.figures.key import key_figure_specs

    specs = {slug: make for slug, _caption, make in key_figure_specs(result)}
    if name not in specs:
        from gradekit.errors import GradekitError

        raise GradekitError(f"expected a figure name ({', '.join(['scene', 'true-scale', *specs])}), got {name!r}")
    return specs[name]()


def figure_names(variant: Variant | Result) -> list[str]:
    """The figures `figure` can draw for this variant."""
    from gradekit.figures.key import key_figure_specs

    result = variant.result if hasattr(variant, "result") else variant
    return ["scene", "true-scale", *(slug for slug, _c, _m in key_figure_specs(result))]


def generate(
    assignment: str | Path,
    roster: str | Path,
    out: str | Path,
    *,
    jobs: int = 1,
    student: str | None = None,
    keys: bool = True,
    progress: bool = False,
):
    """What ``gradekit generate`` does: every student's sheet, answer template and worked key, the
    key CSV, the combined PDFs and the manifest, written into *out*. Returns the run's summary."""
    from gradekit.documents import generate as run

    return run(Path(assignment), Path(roster), Path(out), jobs=jobs, student=student, keys=keys, progress=progress)


def grade(
    assignment: str | Path,
    roster: str | Path,
    submissions: str | Path,
    out: str | Path,
    *,
    manifest: str | Path | None = None,
    reveal: bool = False,
    bank: str | Path | None = None,
    recompute_keys: bool = False,
    carry_forward: bool = False,
    warn=None,
    progress=None,
    exports: list[str] | None = None,
    hand: str | Path | None = None,
):
    """What ``gradekit grade`` does: grade every submission against the class's keys and write
    grades, LMS exports, feedback and the report into *out*. Returns the batch result.

    With a *manifest*, the keys are those `generate` froze beside it (``keys.json``): nothing is
    re-sampled, and a later change of the bank, the tolerance table or gradekit changes no grade.
    *recompute_keys* grades against keys recomputed from the current bank instead (with the
    manifest's re-draws). *warn* receives each warning line; ignored when None. *progress* is
    called with (problems done, problems) while keys are derived for the class. *carry_forward*
    gives carried-forward credit on every problem whose assignment entry does not turn it off
    (``carry_forward:`` in the assignment turns it on without the option). *exports* names what to
    write (`gradekit.grading.exports.EXPORTS`), over the assignment's ``exports:``. *hand* is a filled
    ``hand.csv``: the points the instructor gave to the answers checked by hand (`gradekit.grading.hand`).
    """
    return _grade(assignment, roster, submissions, out, manifest, reveal, bank, recompute_keys, carry_forward, warn,
                  progress, exports, hand)


def _grade(assignment, roster, submissions, out, manifest, reveal, bank, recompute_keys, carry_forward, warn,
           progress, exports=None, hand=None):
    from gradekit.assignment import check_manifest, class_keys, frozen_keys, load_assignment, redraws_from_manifest
    from gradekit.grading.batch import grade_batch
    from gradekit.grading.exports import choose_exports
    from gradekit.roster import canvas_assignment_id, read_roster

    def say(text: str) -> None:
        if warn is not None:
            warn(text)

    asg = load_assignment(assignment, bank)
    chosen = choose_exports(exports, field="--exports") if exports is not None else asg.exports
    students = read_roster(Path(roster))
    ids = [s.student_id for s in students]
    redraws = None
    frozen = None
    if manifest:
        notes = check_manifest(asg, Path(manifest))
        redraws = redraws_from_manifest(Path(manifest))
        frozen = None if recompute_keys else frozen_keys(Path(manifest))
        if frozen is None and not recompute_keys:
            say("the manifest holds no frozen keys (written by an older gradekit): keys are derived from the "
                "current bank with the manifest's re-draws")
        for note in notes:
            say(note)
        if notes and frozen is not None:
            say("graded against the keys frozen at generation (keys.json); --recompute-keys grades against the "
                "current bank instead")
    if frozen is not None:
        keys = _frozen_class(frozen, ids, lambda missing: class_keys(asg, missing, redraws)[0], say)
    else:
        done = []

        def step(label: str) -> None:
            done.append(label)
            if progress is not None:
                progress(len(done), len(asg.items))

        keys, variants = class_keys(asg, ids, redraws, progress=step)
    from gradekit.grading.carried import class_carry

    carry = class_carry(asg, ids, redraws, keys, say, forced=carry_forward,
                        variants=None if frozen is not None else variants)
    titles = {it.label: f"{it.label}: {it.problem.title}" for it in asg.items}
    return grade_batch(
        keys, students, Path(submissions), Path(out), assignment_title=asg.title, reveal=reveal, problem_titles=titles,
        hint=asg.feedback, carry=carry, exports=chosen,
        canvas_assignment_id=canvas_assignment_id(Path(roster), asg.title), partial=asg.partial_credit(),
        hand=Path(hand) if hand is not None else None,
    )


def _frozen_class(frozen, ids, compute, say):
    """The class's key entries from the frozen keys (``{student: entries}``): the roster's students in the
    file in roster order, then those whose keys are *compute*d now (not on the roster at generation)."""
    present = [s for s in ids if s in frozen]
    missing = [s for s in ids if s not in frozen]
    keys = [e for s in present for e in frozen[s]]
    if missing:
        say(f"{len(missing)} roster student(s) have no frozen key (not on the roster at generation: "
            f"{', '.join(missing[:5])}{'…' if len(missing) > 5 else ''}); their keys are computed now")
        keys += compute(missing)
    return keys
