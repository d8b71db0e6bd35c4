"""Copy detection on a synthetic class whose outcome follows from how it is built.

300 students, 3 problems whose answers are products of the same 3 drawn inputs (so answers of one
problem are correlated, as in a real mechanism), ±2 % bands. Guessers answer anywhere in the
class's range; one-wrong-input students carry ×1.1 through every answer of one problem; copiers
hand in a named classmate's answers with one changed; one pair hands in the same wrong values on a
whole problem (wrong for both), each doing the other problems alone.
"""

from __future__ import annotations

import itertools
import random

import numpy as np
import pytest

from gradekit.grading.compare import grade_student
from gradekit.grading.integrity import KEY_MATCH, SHARED_WRONG, find_copies, poisson_binomial_tails
from gradekit.grading.reader import Answer, Submission
from gradekit.roster import Student
from gradekit.solving.keys import KeyEntry, Tolerance

N = 300
TOL = Tolerance("relative", rel=0.02)


def answers_of(a: float, b: float, c: float) -> list[float]:
    return [a * b, a / c, 10 * b * c, a * a * c, b / a]


def sig4(x: float) -> float:
    return float(f"{x:.4g}")


@pytest.fixture(scope="module")
def klass():
    rng = random.Random(11)
    ids = [f"{20000 + i}" for i in range(N)]
    keys: list[KeyEntry] = []
    for sid in ids:
        for p in ("p1", "p2", "p3"):
            inputs = [rng.uniform(1, 3) for _ in range(3)]
            for k, v in enumerate(answers_of(*inputs)):
                keys.append(KeyEntry(sid, p, f"{p}.a{k}", v, "N", TOL))
    entries = {sid: [e for e in keys if e.student_id == sid] for sid in ids}
    span = {
        e.key: (min(x.value for x in keys if x.key == e.key), max(x.value for x in keys if x.key == e.key))
        for e in entries[ids[0]]
    }
    kind: dict[str, str] = {}
    values: dict[str, dict[str, float]] = {}
    for i, sid in enumerate(ids):
        own = {e.key: sig4(e.value) for e in entries[sid]}
        if i < 30:
            kind[sid] = "guesser"
            values[sid] = {k: sig4(rng.uniform(*span[k])) for k in own}
        elif i < 60:
            kind[sid] = "one wrong input"
            wrong = rng.choice(("p1", "p2", "p3"))
            values[sid] = {k: sig4(v * 1.1) if k.startswith(wrong) else v for k, v in own.items()}
        else:
            kind[sid] = "honest"
            values[sid] = own
    source = {}
    for i in range(60, 70):  # copiers of honest students 100..109, one answer changed
        sid, src = ids[i], ids[100 + i - 60]
        kind[sid], source[sid] = "copier", src
        values[sid] = dict(values[src])
        values[sid]["p2.a1"] = sig4(rng.uniform(*span["p2.a1"]))
    a, b = ids[200], ids[201]  # the pair: the same wrong p2, each their own p1 and p3
    shared = {e.key: sig4(e.value * 1.3) for e in entries[a] if e.problem == "p2"}
    values[a].update(shared)
    values[b].update(shared)
    grades = []
    for sid in ids:
        ans = tuple(Answer(k, repr(v), "", v, "", n) for n, (k, v) in enumerate(values[sid].items(), start=2))
        grades.append(grade_student(Student(sid, sid), entries[sid], Submission(f"{sid}.csv", sid, ans)))
    return grades, keys, kind, source, (a, b)


def test_guessers_and_one_wrong_input_are_not_accused(klass) -> None:
    grades, keys, kind, _, pair = klass
    flags = find_copies(grades, keys)
    accused = {f.student_id for f in flags} | {f.other_id for f in flags if f.reason == SHARED_WRONG}
    independent = {s for s, k in kind.items() if k in ("guesser", "one wrong input", "honest")} - set(pair)
    assert not accused & independent


def test_copiers_are_flagged_with_the_classmate_named(klass) -> None:
    grades, keys, _, source, _ = klass
    flags = find_copies(grades, keys)
    named = {(f.student_id, f.other_id) for f in flags if f.reason == KEY_MATCH}
    assert set(source.items()) <= named
    flag = next(f for f in flags if f.student_id == "20060")
    assert flag.other_matches >= 12 and "p2.a1" not in flag.keys  # 14 copied, less any inside their own band
    assert flag.p_value is not None and flag.p_value < 1e-3
    assert f"20060 matches {source['20060']}'s key on {flag.other_matches} answers" in flag.describe()
    assert "1 in" in flag.describe()


def test_pair_sharing_wrong_answers_is_flagged(klass) -> None:
    grades, keys, _, _, pair = klass
    flags = [f for f in find_copies(grades, keys) if f.reason == SHARED_WRONG]
    assert [(f.student_id, f.other_id) for f in flags] == [pair]
    flag = flags[0]
    assert flag.keys == tuple(f"p2.a{k}" for k in range(5))
    assert flag.p_value is not None and flag.p_value < 1e-3
    assert "20200 and 20201 give the same wrong values on 5 answers" in flag.describe()
    assert "20201.csv" in flag.describe()


def test_stricter_threshold_flags_fewer() -> None:
    """A copier who hands in a classmate's key on 4 of 6 answers is flagged at the default alpha; at an
    alpha below the flag's own corrected chance they are not; two answers matched by chance in a class
    of three are never flagged."""
    rng = random.Random(7)
    ids = [f"s{i}" for i in range(40)]
    keys = [KeyEntry(s, "p", f"p.a{k}", rng.uniform(10, 100), "N", TOL) for s in ids for k in range(6)]
    entries = {s: [e for e in keys if e.student_id == s] for s in ids}
    theirs = [e.value for e in entries["s1"]]
    mine = [e.value for e in entries["s0"]]
    copied = theirs[:4] + mine[4:]
    ans = tuple(Answer(f"p.a{k}", str(v), "", v, "", k + 2) for k, v in enumerate(copied))
    grades = [grade_student(Student("s0", "s0"), entries["s0"], Submission("s0.csv", "s0", ans))]
    flagged = find_copies(grades, keys)
    assert [(f.student_id, f.other_id) for f in flagged] == [("s0", "s1")]
    assert flagged[0].p_value is not None and flagged[0].p_value < 1e-3
    assert find_copies(grades, keys, alpha=flagged[0].p_value / 10) == []

    small = [
        KeyEntry(s, "p", f"p.a{k}", v, "N", TOL)
        for s, vs in (("a", (1, 2)), ("b", (5, 6)), ("c", (9, 9)))
        for k, v in enumerate(vs)
    ]
    ans = (Answer("p.a0", "5", "", 5.0, "", 2), Answer("p.a1", "6", "", 6.0, "", 3))
    own = [e for e in small if e.student_id == "a"]
    grades = [grade_student(Student("a", "a"), own, Submission("a.csv", "a", ans))]
    assert find_copies(grades, small) == []


def test_poisson_binomial_tails_match_enumeration() -> None:
    p = np.array([[0.1, 0.5, 0.02, 0.3]])
    tails = poisson_binomial_tails(p)[0]
    for m in range(5):
        exact = sum(
            np.prod([q if hit else 1 - q for q, hit in zip(p[0], outcome, strict=True)])
            for outcome in itertools.product((0, 1), repeat=4)
            if sum(outcome) >= m
        )
        assert tails[m] == pytest.approx(exact)
