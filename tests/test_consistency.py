"""Generation and grading see the same variants: class de-duplication and explicit re-draws."""

from __future__ import annotations

from pathlib import Path

from gradekit.assignment import class_keys, class_redraws, load_assignment
from gradekit.solving.sampling import variant


def _assignment(tmp_path: Path, extra: str = "") -> Path:
    f = tmp_path / "a.yaml"
    f.write_text(
        "title: T\ncourse: MEG373\nsalt: s1\nbank: " + str(Path("problem_bank").resolve()) + "\n"
        "problems:\n  - {id: ch5-ex5-1, points: 10}\n" + extra,
        encoding="utf-8",
    )
    return f


def test_explicit_redraw_changes_one_student_only(tmp_path):
    ids = [f"s{i}" for i in range(20)]
    base = load_assignment(_assignment(tmp_path))
    keys0, var0 = class_keys(base, ids, with_mistakes=False)
    redrawn = load_assignment(_assignment(tmp_path, "redraws:\n  s3: {p1: 1}\n"))
    keys1, var1 = class_keys(redrawn, ids, with_mistakes=False)
    assert var1["s3"]["p1"].values != var0["s3"]["p1"].values
    assert var1["s3"]["p1"].values == variant(base.items[0].problem, course="MEG373", salt="s1",
                                              student="s3", redraw=1).values
    for s in ids:
        if s != "s3":
            assert var1[s]["p1"].values == var0[s]["p1"].values
    assert class_redraws(redrawn, ids)["s3"] == {"p1": 1}


def test_manifest_counters_reproduce_generation_exactly(tmp_path):
    ids = [f"s{i}" for i in range(40)]
    asg = load_assignment(_assignment(tmp_path))
    counters = class_redraws(asg, ids)
    keys_a, _ = class_keys(asg, ids, with_mistakes=False)
    keys_b, _ = class_keys(asg, ids, redraws=counters, with_mistakes=False)
    assert [(k.student_id, k.key, k.value) for k in keys_a] == [(k.student_id, k.key, k.value) for k in keys_b]


def test_assignment_tolerance_overrides_lay_over_the_measured_tolerance(tmp_path):
    from gradekit.bank.registry import load_bank

    f = tmp_path / "o.yaml"
    f.write_text(
        "title: T\ncourse: MEG373\nsalt: s1\nbank: " + str(Path("problem_bank").resolve()) + "\n"
        "problems:\n  - {id: ch5-ex5-3, points: 10, tolerance: {rel: 0.05}, tolerances: {T: {abs: 40}}}\n",
        encoding="utf-8",
    )
    asg = load_assignment(f)
    keys, _ = class_keys(asg, ["s1"], with_mistakes=False)
    by = {k.key: k.tolerance for k in keys}
    spec = {a.key: a.tolerance for a in load_bank()["ch5-ex5-3"].answers}
    assert by["p1.aG2"].rel == 0.05 and by["p1.aG2"].floor == spec["aG2"].floor  # only rel replaced
    assert by["p1.aG2_dir"].period == 360.0  # angles keep their wrap
    assert by["p1.T"].abs >= 40 and by["p1.T"].rel == spec["T"].rel  # per-answer field over the measured one
