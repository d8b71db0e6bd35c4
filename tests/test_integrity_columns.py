"""Copy detection reads the frozen keys as columns (`FrozenKeys.columns`) without building a student's
entries: the same class keys, and the same flags, as from the entries."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from test_integrity import klass  # noqa: F401 (the synthetic class: guessers, copiers, a pair)

from gradekit import frozen
from gradekit.grading.integrity import class_keys, find_copies
from gradekit.keys import KeyColumns, KeyEntry, Tolerance


def _same(a, b) -> None:
    assert (a.everyone, a.col, a.names, a.trial_of) == (b.everyone, b.col, b.names, b.trial_of)
    assert np.array_equal(a.period, b.period) and a.per_key.keys() == b.per_key.keys()
    for k in a.per_key:
        for x, y in zip(a.per_key[k], b.per_key[k], strict=True):
            assert np.array_equal(x, y)


def _columns(keys: list[KeyEntry]) -> tuple[KeyColumns, list[str]]:
    loaded = frozen.loads(frozen.dumps(keys), "keys.json")
    order = list(dict.fromkeys(e.student_id for e in keys))
    assert loaded._built == {}
    columns = loaded.columns(order)
    assert loaded._built == {}  # no entry built
    return columns, order


def test_the_columns_hold_each_entrys_value_floor_and_tolerance():
    keys = [
        KeyEntry("1001", "p1", "p1.T", 200.0, "N*m", Tolerance("relative", 0.01, abs=0.5)),
        KeyEntry("1001", "p1", "p1.dir", 359.5, "deg", Tolerance("relative", 0.0, abs=1.0, period=360.0)),
        KeyEntry("1002", "p1", "p1.T", -20.0, "N*m", Tolerance("relative", 0.01, abs=0.75)),
        KeyEntry("1002", "p1", "p1.dir", 0.25, "deg", Tolerance("relative", 0.0, abs=1.0, period=360.0)),
    ]
    columns, _ = _columns(keys)
    assert columns.students == ["1001", "1002"] and columns.counts == [2, 2]
    assert columns.keys == ["p1.T", "p1.dir", "p1.T", "p1.dir"]
    assert columns.values.tolist() == [200.0, 359.5, -20.0, 0.25]
    assert columns.floors.tolist() == [0.5, 1.0, 0.75, 1.0]
    assert [columns.tolerance(i) for i in range(4)] == [e.tolerance for e in keys]
    ck = class_keys(columns)
    values, bands, cols, _ = ck.per_key[0]
    assert values.tolist() == [-20.0, 200.0] and bands.tolist() == [0.75, 2.0] and cols.tolist() == [1, 0]
    values, _, cols, _ = ck.per_key[1]  # the angle, repeated a turn below and above
    assert values.tolist() == [-359.75, -0.5, 0.25, 359.5, 360.25, 719.5] and cols.tolist() == [1, 0, 1, 0, 1, 0]


def test_class_keys_from_columns_equal_those_from_the_entries_with_sigfigs_and_periods():
    rng = random.Random(5)
    modes = {"p1.a": Tolerance("relative", 0.02), "p1.b": Tolerance("sigfigs", 0.0, sigfigs=3),
             "p2.dir": Tolerance("relative", 0.0, abs=0.5, period=360.0)}
    keys = [
        KeyEntry(f"{3000 + i}", key.split(".")[0], key, rng.uniform(-50, 400), "N",
                 Tolerance(t.mode, t.rel, abs=rng.choice((0.0, 0.1, 0.3)), sigfigs=t.sigfigs, period=t.period))
        for i in range(40) for key, t in modes.items()
    ]
    columns, _ = _columns(keys)
    _same(class_keys(columns), class_keys(keys))


def test_copy_detection_from_columns_flags_the_same_students(klass):  # noqa: F811
    grades, keys, *_ = klass
    columns, _ = _columns(keys)
    _same(class_keys(columns), class_keys(keys))
    flags = find_copies(grades, keys)
    assert flags and find_copies(grades, columns) == flags
    assert find_copies(grades, columns, prepared=class_keys(columns)) == flags


def test_a_malformed_row_names_the_file_when_the_columns_are_made():
    from gradekit.errors import GradekitError

    text = frozen.dumps([KeyEntry("1001", "p1", "p1.T", 2.0, "N", Tolerance())]).replace("[2.0,0.0,[]]", '["x",0.0,[]]')
    with pytest.raises(GradekitError, match="expected the frozen keys written by gradekit generate"):
        frozen.loads(text, "keys.json").columns(["1001"])


def test_results_without_a_finite_value_or_of_an_unknown_answer_are_no_evidence(klass):  # noqa: F811
    """Submitted values are read from the results as columns: a result without a value, with NaN or an
    infinity, or of an answer no key has, adds nothing (the same flags as without them)."""
    from dataclasses import replace

    from gradekit.grading.compare import AnswerResult

    grades, keys, *_ = klass
    stranger = KeyEntry(grades[0].student.student_id, "p9", "p9.zz", 1.0, "N", Tolerance())
    padded = []
    for i, g in enumerate(grades):
        extra = ()
        if i % 3 == 0:
            e = g.results[0].entry
            extra = (
                AnswerResult(e, None, None, False, 0.0, None, None),
                AnswerResult(e, None, math.nan, False, 0.0, None, None),
                AnswerResult(e, None, math.inf, False, 0.0, None, None),
                AnswerResult(stranger, None, e.value, False, 0.0, None, None),
            )
        padded.append(replace(g, results=g.results + extra))
    flags = find_copies(grades, keys)
    assert flags and find_copies(padded, keys) == flags
