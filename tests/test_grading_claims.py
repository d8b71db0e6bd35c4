"""The helper's share is settled while both processes work (`parallel.Claims`): each student is taken
exactly once, by whichever process gets there first, and the outputs are those of one process."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from test_grading_parallel import _helper, _run, subs  # noqa: F401 (the class and its folder)

from gradekit.grading import batch, parallel
from gradekit.grading.parallel import Claims, Forked


def test_claims_from_both_ends_meet_without_overlap():
    claims = Claims(10, chunk=3)
    assert list(claims.front()) == [range(0, 3), range(3, 6), range(6, 9), range(9, 10)]
    assert list(claims.back()) == []
    claims.close()
    claims = Claims(10, chunk=4)
    assert claims._take(False) == range(6, 10) and claims._take(True) == range(0, 4)
    assert claims._take(False) == range(4, 6) and claims._take(True) == range(4, 4)
    claims.close()
    assert list(Claims(0).front()) == []


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_a_forked_helper_and_the_parent_take_every_item_once():
    claims = Claims(600, chunk=2)

    def take(takes) -> list[int]:
        got = []
        for taken in takes:
            got += taken
            time.sleep(0.0002)  # some work on each
        return got

    with Forked(lambda: take(claims.back())) as other:
        mine = take(claims.front())
        theirs = other.result()
    claims.close()
    assert sorted(mine + theirs) == list(range(600))
    assert mine and theirs  # both took some
    assert mine == sorted(mine) and mine[0] == 0  # the parent from the front
    assert max(theirs) == 599 and max(mine) < min(theirs)  # the helper from the back


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
@pytest.mark.parametrize("slow", ["helper", "parent"])
def test_whichever_process_is_slower_the_outputs_are_those_of_one(
    subs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, slow: str  # noqa: F811
) -> None:
    alone, alone_files = _run(subs, tmp_path / "alone")
    parent = os.getpid()
    real_graded = batch.grade_student
    by: dict[str, list[str]] = {"parent": [], "helper": []}  # who graded whom

    def timed(student, *args):
        here = "parent" if os.getpid() == parent else "helper"
        if here == slow:
            time.sleep(0.02)
        by[here].append(student.student_id)
        return real_graded(student, *args)

    monkeypatch.setattr(batch, "grade_student", timed)
    unpacked: list[str] = []  # the students whose grade the helper sent

    class Counted(batch.PackedGrade):
        def __init__(self, data, student, entries):
            unpacked.append(student.student_id)
            super().__init__(data, student, entries)

    monkeypatch.setattr(batch, "PackedGrade", Counted)
    _helper(monkeypatch, 1.0)
    helped, helped_files = _run(subs, tmp_path / "helped")
    assert helped_files == alone_files
    assert helped.grades == alone.grades and helped.files == alone.files and helped.flags == alone.flags
    in_parent = [sid for sid in by["parent"] if sid not in unpacked]  # (the helper's calls stay in the helper)
    print(slow, len(unpacked), len(in_parent))
    assert unpacked and in_parent  # both graded some of the class
    if slow == "helper":  # the parent took most of the share from the front
        assert len(unpacked) < len(in_parent)
    else:
        assert len(unpacked) > len(in_parent)


@pytest.mark.skipif(not parallel.available(), reason="needs fork and two cores")
def test_a_stream_hands_over_what_the_helper_sends_as_it_goes_without_either_waiting():
    from gradekit.grading.parallel import Stream

    stream = Stream()
    big = "x" * 200_000  # several times what a pipe holds: the helper never blocks on it

    def helper() -> int:
        for i in range(50):
            stream.send((i, big if i % 10 == 0 else i * 1.5))
        return 50

    got = []
    with Forked(helper) as other:
        while len(got) < 50:  # the parent looks whenever it likes; nothing is lost or torn
            got += stream.receive()
            time.sleep(0.001)
        assert other.result() == 50
    assert stream.receive() == []
    stream.close()
    assert got == [(i, big if i % 10 == 0 else i * 1.5) for i in range(50)]


def test_a_stream_received_in_the_process_that_sent_it():
    from gradekit.grading.parallel import Stream

    stream = Stream()
    assert stream.receive() == []
    stream.send({"a": [1, 2.5]})
    stream.send(None)
    assert stream.receive() == [{"a": [1, 2.5]}, None]
    assert stream.receive() == []
    stream.close()
