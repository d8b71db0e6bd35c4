"""The frozen keys make an entry's catalogued mistakes only when they are first read (most answers are
right and never read them): the entry is the same in value and behaviour as one made with them."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import pytest

from gradekit import frozen
from gradekit.errors import GradekitError
from gradekit.grading.compare import compare
from gradekit.grading.reader import Answer
from gradekit.keys import KeyEntry, Mistake, Tolerance

TOL = Tolerance("relative", 0.01, abs=0.5)


def _keys() -> list[KeyEntry]:
    return [
        KeyEntry("1001", "p1", "p1.T", 12.5, "N*m", TOL, 2.0, "torque", "ccw+",
                 (Mistake("static-answer", "a static answer", 10.0), Mistake("no-gravity", "gravity left out", 30.0))),
        KeyEntry("1001", "p1", "p1.F", -3.0, "N", TOL, 1.0, "force"),
    ]


def _loaded() -> list[KeyEntry]:
    return frozen.loads(frozen.dumps(_keys()), "keys.json")["1001"]


def test_mistakes_are_made_when_first_read_and_kept():
    torque, force = _loaded()
    assert "mistakes" not in vars(torque)  # not made yet
    assert force.mistakes == ()  # none: nothing deferred
    made = torque.mistakes
    assert made == (Mistake("static-answer", "a static answer", 10.0), Mistake("no-gravity", "gravity left out", 30.0))
    assert type(made[1].value) is float and made[1].value == 30.0
    assert torque.mistakes is made and "_mistakes_later" not in vars(torque)


def test_a_deferred_entry_equals_the_eager_one_in_value_and_behaviour():
    eager = _keys()
    assert _loaded() == eager
    assert [hash(e) for e in _loaded()] == [hash(e) for e in eager]
    assert [repr(e) for e in _loaded()] == [repr(e) for e in eager]
    assert [dataclasses.replace(e) for e in _loaded()] == eager
    assert [dataclasses.astuple(e) for e in _loaded()] == [dataclasses.astuple(e) for e in eager]
    # a wrong answer 30.1 (in the band of no-gravity's 30): diagnosed by the deferred mistakes alike
    answer = Answer("p1.T", "30.1", "", 30.1, "N*m", 2, "value", "")
    assert compare(_loaded()[0], answer) == compare(eager[0], answer)
    assert compare(_loaded()[0], answer).diagnosis == Mistake("no-gravity", "gravity left out", 30.0)


def test_a_copy_or_pickle_of_a_deferred_entry_stands_alone():
    for clone in (pickle.loads(pickle.dumps(_loaded()[0])), copy.copy(_loaded()[0]), copy.deepcopy(_loaded()[0])):
        assert "_mistakes_later" not in vars(clone)
        assert clone == _keys()[0]


def test_the_class_attribute_is_still_the_fields_default():
    assert KeyEntry.mistakes == ()
    assert KeyEntry("1", "p1", "p1.x", 1.0, "N", TOL).mistakes == ()
    assert dataclasses.fields(KeyEntry)[-1].default == ()


@pytest.mark.parametrize("found", ['[["static-answer","x"]]', '[["static-answer"]]', '[1]'])
def test_malformed_mistakes_are_refused_when_the_entry_is_built_not_later(found):
    text = frozen.dumps(_keys()).replace('[["static-answer",10.0],["no-gravity",30.0]]', found)
    assert found in text
    with pytest.raises(GradekitError, match="expected the frozen keys written by gradekit generate"):
        frozen.loads(text, "keys.json")["1001"]
