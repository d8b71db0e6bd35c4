"""Bands that grade (issue 25): honest work admitted, wrong answers rejected, on every bank problem.

One test per goal over sampled variants of every bank problem. Expected values come from the
models: the key solved by gradekit, the answer moved by the perturbation (×1.10, +5°), the
catalogued mistakes re-solved (`gradekit.solving.mistakes`), honest students re-solved from given values
rounded to the precision the sheet asks for; every answer is judged by the band its key carries
(`Tolerance.accepts_many`, the grader's predicate). Answers marked ``hand_check`` are not graded
automatically and are left out. The full honest-student study (3 and 4 figures, drawings on the
printed sheet, 95 % bound) is the slow test at the end.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gradekit.bank.registry import load_bank
from gradekit.solving.mistakes import mistakes_many
from gradekit.solving.pipeline import solve_many
from gradekit.solving.sampling import sample_many, torque_arms

BANK = load_bank()
IDS = sorted(BANK)
VARIANTS = 60
ROOT = Path(__file__).resolve().parents[1]


def _randoms(p) -> bool:
    return any(q.random for q in p.parameters.values())


_DRAWN: dict[str, object] = {}


def drawn(pid: str):
    """The variants of one problem the tests share (the sampler's own draws)."""
    if pid not in _DRAWN:
        p = BANK[pid]
        _DRAWN[pid] = sample_many(p, range(VARIANTS)) if _randoms(p) else sample_many(p, [None])
    return _DRAWN[pid]


def raw_values(vb, batch) -> dict:
    """The parameter values a solved batch of the sampler was drawn with."""
    return next(r[2] for r in vb.rows if r is not None and r[0] is batch)


def graded(batch):
    return [a for a in batch.answer_list if not a.spec.hand_check]


def far_off(a, values):
    """The answer 10 % off, or a direction 5° off (what the issue's second goal names)."""
    return values + 5.0 if a.unit == "deg" else values * 1.10


@pytest.mark.parametrize("pid", IDS)
def test_an_answer_10_percent_off_loses_its_credit(pid):
    vb = drawn(pid)
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        for a in graded(batch):
            v, s = a.value[sel], a.scale[sel]
            kept = a.spec.tolerance.accepts_many(far_off(a, v), v, s)
            assert kept.mean() <= 0.05, f"{pid} {a.key}: 10 % (5°) off earns credit in {kept.mean():.0%} of variants"
            assert a.spec.tolerance.accepts_many(v, v, s).all(), f"{pid} {a.key}: the key itself loses credit"


@pytest.mark.parametrize("pid", IDS)
def test_every_catalogued_mistake_larger_than_10_percent_is_caught(pid):
    """In the variants where a catalogued (or generic) mistake moves the answer more than 10 % (a direction
    more than 5°), it is caught in ≥ 95 % of them; where it moves it less (gravity in a fast machine) it is
    no mistake a band can tell from honest work, and RESULTS gives its size instead."""
    vb = drawn(pid)
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        found = mistakes_many(batch, raw_values(vb, batch), rows=np.isin(np.arange(batch.n), sel))
        for a in graded(batch):
            v, s, tol = a.value[sel], a.scale[sel], a.spec.tolerance
            wrong = {m.name: (m.value[sel], m.changed[sel]) for m in found.get(a.key, [])}
            wrong["sign flipped"] = (-v, v != 0)
            wrong["×1000 unit slip"] = (v * 1000, np.ones(len(v), bool))
            for name, (got, live) in wrong.items():
                d = np.abs(tol.difference(got, v))
                big = live & np.isfinite(got) & ((d > 5.0) if a.unit == "deg" else (d > 0.10 * np.abs(v)))
                if big.any():
                    passed = tol.accepts_many(got[big], v[big], s[big]).mean()
                    assert passed <= 0.05, f"{pid} {a.key}: {name} earns credit in {passed:.0%} of the variants"


def test_a_class_10_percent_off_keeps_at_most_a_tenth_of_the_points():
    """One assignment holding every bank problem (10 points each, shared by answer points): a class whose
    every automatically graded answer is 10 % off (directions 5°) keeps ≤ 10 % of the points, the key 100 %."""
    kept = key = total = 0.0
    for pid in IDS:
        p = BANK[pid]
        weights = sum(a.points for a in p.answers if not a.hand_check)
        if not weights:
            continue
        vb = drawn(pid)
        n = len(vb)
        for batch, rows in vb.by_batch():
            sel = np.asarray(rows)
            for a in graded(batch):
                cases = sum(1 for b in batch.answer_list if b.spec is a.spec)
                w = 10.0 * a.spec.points / weights / cases
                v, s = a.value[sel], a.scale[sel]
                kept += w * a.spec.tolerance.accepts_many(far_off(a, v), v, s).sum() / n
                key += w * a.spec.tolerance.accepts_many(v, v, s).sum() / n
        total += 10.0
    assert key == pytest.approx(total)
    assert kept / total <= 0.10, f"the class 10 % off keeps {kept / total:.1%} of the points"


def _sig_error(x, sig, rng):
    x = np.asarray(x, float)
    e = np.floor(np.log10(np.abs(np.where(x != 0, x, 1.0)))) - sig + 1
    return x + rng.uniform(-0.5, 0.5, x.shape) * np.where(x != 0, 10.0**e, 0.0)


def _sig_round(x, sig):
    x = np.asarray(x, float)
    e = np.floor(np.log10(np.abs(np.where(x != 0, x, 1.0)))) - sig + 1
    return np.where(x != 0, np.round(x / 10.0**e) * 10.0**e, x)


@pytest.mark.parametrize("pid", [i for i in IDS if BANK[i].method == "analytical"])
def test_honest_work_at_the_sheets_precision_is_admitted(pid):
    """Students who take every given value to the significant figures the sheet asks for (±½ in the last
    digit), solve exactly and write each answer to that many figures all earn full credit."""
    p, rng = BANK[pid], np.random.default_rng(25)
    vb = drawn(pid)
    k = 8
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        raw = raw_values(vb, batch)
        vals = {n: np.repeat(np.broadcast_to(np.asarray(v, float), (batch.n,))[sel], k) for n, v in raw.items()}
        given = {n: (_sig_error(v, p.sigfigs, rng) if n in p.parameters and not p.parameters[n].expr else v)
                 for n, v in vals.items()}
        student = solve_many(p, given, len(sel) * k)
        for a, b in zip(batch.answer_list, student.answer_list, strict=True):
            if a.spec.hand_check:
                continue
            v, s = np.repeat(a.value[sel], k), np.repeat(a.scale[sel], k)
            got = _sig_round(b.value, p.sigfigs)
            ok = a.spec.tolerance.accepts_many(got, v, s) | ~student.ok
            # the 95 % bound below 0.1 % is the slow study's; on these few hundred students at most one in 200
            assert (~ok).mean() <= 0.005, f"{pid} {a.key}: {int((~ok).sum())} of {len(ok)} honest answers rejected"


@pytest.mark.parametrize("pid", [i for i in IDS if BANK[i].method == "graphical" and _randoms(BANK[i])])
def test_no_graphical_torque_is_read_off_a_polygon_with_nearly_parallel_sides(pid):
    """The gradability rule: every drawn torque is at least ARM_MIN of the moment its polygon's largest
    force would have at the crank pin (|T| over F_max·r, recomputed here from the solved forces)."""
    from gradekit.solving.tolerances import ARM_MIN

    vb = drawn(pid)
    for batch, rows in vb.by_batch():
        arms = torque_arms(BANK[pid], batch)
        for key, share in arms.items():
            spec = next(a.spec for a in batch.answer_list if a.key == key)
            if not spec.hand_check:
                assert (share[np.asarray(rows)] >= ARM_MIN).all(), f"{pid} {key}"


@pytest.mark.parametrize("pid", [i for i in IDS if _randoms(BANK[i])])
def test_every_drawn_answer_is_at_least_10_5_bands_from_zero(pid):
    """The gradability rule on every automatically graded answer: |v| ≥ gradable · band, so the band is
    at most 1/10.5 of the answer (the published variant of a problem without random values is not drawn)."""
    vb = drawn(pid)
    for batch, rows in vb.by_batch():
        sel = np.asarray(rows)
        for a in graded(batch):
            if a.unit != "deg":
                band = a.spec.tolerance.bands(a.value[sel], a.scale[sel])
                assert (np.abs(a.value[sel]) >= BANK[pid].constraints.gradable * band * (1 - 1e-9)).all(), a.key


def test_statements_ask_for_the_precision_the_bands_assume():
    """A problem's ``sigfigs`` is printed in its statement; a graphical statement prints the reading
    accuracy and polygon size the drawing model assumes (gradekit.solving.tolerances)."""
    from gradekit.solving.tolerances import POLYGON_MM, READ_DEG, READ_MM

    for pid, p in BANK.items():
        if p.sigfigs != 3:
            assert f"{p.sigfigs} significant figures" in p.statement, pid
        if p.method == "graphical":
            text = " ".join(p.statement.split())
            assert f"lengths to {READ_MM:g} mm and directions to {READ_DEG:g}°" in text, pid
            assert f"largest vector {POLYGON_MM[0]:g} to {POLYGON_MM[1]:g} mm long" in text, pid


def test_hand_check_must_be_true_or_false(tmp_path):
    from gradekit.bank.schema import load_problem
    from gradekit.errors import ErrorList

    src = (ROOT / "problem_bank" / "ch5_ex5_1_slider_crank_static.yaml").read_text(encoding="utf-8")
    line = next(ln for ln in src.splitlines() if ln.startswith("  - {key: F23,"))
    f = tmp_path / "p.yaml"
    f.write_text(src.replace(line, line[:-1] + ", hand_check: maybe}"), encoding="utf-8")
    with pytest.raises(ErrorList) as err:
        load_problem(f)
    msg = str(err.value.errors[0])
    assert "hand_check" in msg and "expected true or false, got 'maybe'" in msg and "p.yaml" in msg
    f.write_text(src.replace(line, line[:-1] + ", hand_check: true}"), encoding="utf-8")
    p = load_problem(f)
    assert "F23" in [a.key for a in p.answers if a.hand_check]


@pytest.mark.slow
@pytest.mark.parametrize("pid", IDS)
def test_the_honest_study_stays_below_a_tenth_of_a_percent(pid, monkeypatch):
    """The full honest-student study (benchmarks/tolerance_study.py: every given value and intermediate
    to the sheet's figures and one more, and the drawing on the printed sheet for graphical problems):
    every automatically graded answer's 95 % upper bound of the false-reject rate is below 0.1 %."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # the study lives with the benchmarks; restored after
    import tolerance_study as ts

    from gradekit.figures.sheet import printed_scale

    p = BANK[pid]
    st = ts.simulate(p, 500, 20, printed_scale=printed_scale)  # as the table (derive_tolerances) measures
    specs = {a.key: a for a in p.answers}
    for key, a in st.answers.items():
        if specs[key].hand_check:
            continue
        s = ts.evaluate(a, specs[key].tolerance, st.models)
        assert s.worst_bound() < 0.001, f"{pid} {key}: {s.rejected} of {s.samples}"


def _bank_check(*args):
    from click.testing import CliRunner

    from gradekit.cli import main

    return CliRunner().invoke(main, ["bank", "check", *args])


def test_bank_check_reports_both_sides_with_a_legend():
    r = _bank_check("ch5-ex5-1", "--variants", "30", "--class-size", "20")
    assert "columns: answer | band the grader applies | honest:" in r.output
    row = next(ln for ln in r.output.splitlines() if ln.strip().startswith("F23 ") and "honest" in ln)
    assert "10%/5°" in row and "mistake" in row and row.rstrip().endswith("ok")
    assert r.exit_code == 0, r.output


def test_bank_check_fails_a_band_that_passes_an_answer_10_percent_off(tmp_path):
    """The same problem with F23's band widened to ±12 % (and the gradability rule off, so the draws
    stay as they were): an answer 10 % off would earn full credit, and bank check says so."""
    src = (ROOT / "problem_bank" / "ch5_ex5_1_slider_crank_static.yaml").read_text(encoding="utf-8")
    start = src.index("    F23: {")
    end = src.index("\n", start)
    text = src[:start] + "    F23: {rel: 0.12}" + src[end:]
    text = text.replace("constraints:\n", "constraints:\n  gradable: 0\n", 1)
    f = tmp_path / "p.yaml"
    f.write_text(text, encoding="utf-8")
    r = _bank_check(str(f), "--variants", "20", "--class-size", "5")
    assert r.exit_code == 1
    assert "F23: an answer 10 % (5°) off earns full credit in 100.0% of variants" in r.output
